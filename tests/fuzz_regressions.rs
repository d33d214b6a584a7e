//! Regression tests from fuzzing the scene loader (fuzz/, ROBUSTNESS.md "Fuzzing").
//!
//! Every file under tests/data/fuzz/ (the scene files the fuzz target made from inputs that
//! crashed, hung or broke an invariant, minimized) and under tests/data/bad/ is loaded through
//! the library, with the fuzz target's memory limit. Each must return `Ok` or `Err` without
//! panicking, within a time bound; an `Ok` scene must satisfy the invariants the renderer
//! relies on (one without triangles must say so), and an `Err` must be one line naming the file.

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use strata::scene::{self, LoadOptions, Scene};

/// Far above any of these files' load time (milliseconds), far below a hang.
const TIME_LIMIT: Duration = Duration::from_secs(10);

fn files(dir: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gltf" || e == "glb"))
        .collect();
    out.sort();
    out
}

fn check_invariants(path: &Path, s: &Scene) {
    let what = path.display();
    let n = s.positions.len();
    // A scene without triangles is valid (it renders its environment alone), and says so.
    assert!(
        !s.triangles.is_empty() || s.load_warnings.iter().any(|w| w.contains("no triangles")),
        "{what}: an empty scene without its warning"
    );
    assert_eq!(s.normals.len(), n, "{what}");
    assert_eq!(s.uvs.len(), n, "{what}");
    assert_eq!(s.triangle_materials.len(), s.triangles.len(), "{what}");
    assert!(
        s.triangles.iter().flatten().all(|&i| (i as usize) < n),
        "{what}: vertex index out of range"
    );
    assert!(
        s.triangle_materials
            .iter()
            .all(|&m| (m as usize) < s.materials.len()),
        "{what}: material index out of range"
    );
    assert!(s.positions.iter().all(|p| p.is_finite()), "{what}");
    assert!(s.normals.iter().all(|v| v.is_finite()), "{what}");
    assert!(s.bounds.0.is_finite() && s.bounds.1.is_finite(), "{what}");
    assert!(s.cameras.iter().all(|c| c.to_world.is_finite()), "{what}");
}

/// Loads `path` on its own thread; `Err` if it panicked or ran past [`TIME_LIMIT`].
fn load_bounded(path: &Path) -> Result<Result<Scene, String>, String> {
    let (tx, rx) = mpsc::channel();
    let p = path.to_path_buf();
    let t0 = Instant::now();
    let handle = std::thread::spawn(move || {
        let options = LoadOptions {
            memory_limit: Some(256 << 20),
            other_memory: 0,
            environment_memory: 0,
            pose: None,
            flatten_instances: false,
        };
        let result = scene::load(&p, &options).map_err(|e| e.to_string());
        let _ = tx.send(result);
    });
    match rx.recv_timeout(TIME_LIMIT) {
        Ok(result) => {
            handle.join().unwrap();
            Ok(result)
        }
        Err(mpsc::RecvTimeoutError::Disconnected) => {
            Err(format!("panicked after {:?}", t0.elapsed()))
        }
        Err(mpsc::RecvTimeoutError::Timeout) => Err(format!("still loading after {TIME_LIMIT:?}")),
    }
}

fn check_all(dir: &str) -> usize {
    let files = files(dir);
    let mut failures = Vec::new();
    for path in &files {
        match load_bounded(path) {
            Ok(Ok(scene)) => check_invariants(path, &scene),
            Ok(Err(message)) => {
                let name = path.file_name().unwrap().to_string_lossy();
                assert!(
                    message.contains(&*name) && !message.contains('\n'),
                    "{}: the error should be one line naming the file: {message}",
                    path.display()
                );
            }
            Err(e) => failures.push(format!("{}: {e}", path.display())),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    files.len()
}

#[test]
fn fuzz_findings_load_or_fail_cleanly() {
    let n = check_all("tests/data/fuzz");
    assert!(n > 0, "tests/data/fuzz holds no regression files");
}

#[test]
fn bad_files_load_or_fail_cleanly() {
    check_all("tests/data/bad");
}
