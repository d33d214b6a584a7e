//! Finds the system Embree and generates its bindings; builds the C interface to the system
//! Draco decoder (`draco_shim`).
//!
//! Search order (DESIGN.md), Embree 4 before Embree 3 at every step:
//! 1. `EMBREE_DIR`: a prefix holding `include/embree{4,3}/rtcore.h` and `lib{,64}/libembree{4,3}.so`;
//! 2. pkg-config (`embree4`, then `embree3`);
//! 3. CMake config directories (`<libdir>/cmake/embree-X.Y.Z/`, which is all Debian 12's
//!    `libembree-dev` ships) and the default include paths.
//!
//! `STRATA_EMBREE_VERSION=3|4` restricts the search to one major version.
//! Emits `cfg(embree4)` or `cfg(embree3)` and `STRATA_EMBREE_HEADER_VERSION`.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

#[derive(Debug)]
struct Found {
    major: u32,
    include_dir: PathBuf,
    /// Directory to add to the linker search path; `None` when the linker finds it by default.
    lib_dir: Option<PathBuf>,
    how: String,
}

const INSTALL_HINT: &str = "strata needs Intel Embree 4 or Embree 3.13 (headers and library). \
Install it: Debian 12: `apt-get install libembree-dev` (Embree 3.13); \
Debian 13 / Ubuntu 24.04: `apt-get install libembree-dev` (Embree 4); \
Homebrew: `brew install embree`; \
or set EMBREE_DIR to a prefix containing include/embree4/rtcore.h and lib/libembree4.so \
(or the embree3 equivalents).";

fn lib_name(major: u32) -> String {
    format!("embree{major}")
}

fn header_in(include_dir: &Path, major: u32) -> PathBuf {
    include_dir.join(format!("embree{major}")).join("rtcore.h")
}

fn find_lib_dir(prefix: &Path, major: u32) -> Option<PathBuf> {
    let names = [
        format!("lib{}.so", lib_name(major)),
        format!("lib{}.dylib", lib_name(major)),
        format!("{}.lib", lib_name(major)),
    ];
    [
        "lib",
        "lib64",
        "lib/x86_64-linux-gnu",
        "lib/aarch64-linux-gnu",
    ]
    .iter()
    .map(|d| prefix.join(d))
    .find(|d| names.iter().any(|n| d.join(n).exists()))
}

fn from_embree_dir(majors: &[u32]) -> Option<Result<Found, String>> {
    let dir = PathBuf::from(env::var_os("EMBREE_DIR")?);
    for &major in majors {
        let include = dir.join("include");
        if header_in(&include, major).exists() {
            return Some(match find_lib_dir(&dir, major) {
                Some(lib) => Ok(Found {
                    major,
                    include_dir: include,
                    lib_dir: Some(lib),
                    how: format!("EMBREE_DIR={}", dir.display()),
                }),
                None => Err(format!(
                    "EMBREE_DIR={} has include/embree{major}/rtcore.h but no lib/lib{}.so",
                    dir.display(),
                    lib_name(major)
                )),
            });
        }
    }
    Some(Err(format!(
        "EMBREE_DIR={} holds neither include/embree4/rtcore.h nor include/embree3/rtcore.h",
        dir.display()
    )))
}

fn from_pkg_config(major: u32) -> Option<Found> {
    let lib = pkg_config::Config::new()
        .cargo_metadata(false)
        .probe(&lib_name(major))
        .ok()?;
    let include_dir = lib
        .include_paths
        .iter()
        .find(|p| header_in(p, major).exists())
        .cloned()
        .or_else(|| {
            default_include_dirs()
                .into_iter()
                .find(|p| header_in(p, major).exists())
        })?;
    Some(Found {
        major,
        include_dir,
        lib_dir: lib.link_paths.first().cloned(),
        how: format!("pkg-config {} {}", lib_name(major), lib.version),
    })
}

fn default_include_dirs() -> Vec<PathBuf> {
    [
        "/usr/include",
        "/usr/local/include",
        "/opt/homebrew/include",
    ]
    .iter()
    .map(PathBuf::from)
    .collect()
}

fn default_lib_dirs() -> Vec<PathBuf> {
    [
        "/usr/lib/x86_64-linux-gnu",
        "/usr/lib/aarch64-linux-gnu",
        "/usr/lib64",
        "/usr/lib",
        "/usr/local/lib",
        "/opt/homebrew/lib",
    ]
    .iter()
    .map(PathBuf::from)
    .collect()
}

/// CMake config directories (`<libdir>/cmake/embree-X.Y.Z`) and the default include paths.
fn from_default_paths(major: u32) -> Option<Found> {
    let include_dir = default_include_dirs()
        .into_iter()
        .find(|p| header_in(p, major).exists())?;
    let mut cmake_version = None;
    let mut lib_dir = None;
    for libdir in default_lib_dirs() {
        if let Ok(entries) = fs::read_dir(libdir.join("cmake")) {
            for e in entries.flatten() {
                let name = e.file_name().to_string_lossy().into_owned();
                if let Some(v) = name.strip_prefix("embree-") {
                    if v.starts_with(&format!("{major}.")) {
                        cmake_version = Some(v.to_string());
                        lib_dir = Some(libdir.clone());
                    }
                }
            }
        }
        if lib_dir.is_none() && libdir.join(format!("lib{}.so", lib_name(major))).exists() {
            lib_dir = Some(libdir.clone());
        }
    }
    let lib_dir = lib_dir?;
    Some(Found {
        major,
        include_dir,
        how: match cmake_version {
            Some(v) => format!("CMake config embree-{v} in {}", lib_dir.display()),
            None => format!("default paths ({})", lib_dir.display()),
        },
        lib_dir: Some(lib_dir),
    })
}

fn find_embree() -> Result<Found, String> {
    let majors: Vec<u32> = match env::var("STRATA_EMBREE_VERSION").ok().as_deref() {
        Some("4") => vec![4],
        Some("3") => vec![3],
        Some("") | None => vec![4, 3],
        Some(other) => return Err(format!("STRATA_EMBREE_VERSION={other}: expected 3 or 4")),
    };
    if let Some(found) = from_embree_dir(&majors) {
        return found;
    }
    for &major in &majors {
        if let Some(found) = from_pkg_config(major) {
            return Ok(found);
        }
    }
    for &major in &majors {
        if let Some(found) = from_default_paths(major) {
            return Ok(found);
        }
    }
    Err("Embree was not found.".to_string())
}

/// Reads `RTC_VERSION_STRING` from `rtcore_config.h`.
fn header_version(found: &Found) -> String {
    let config = found
        .include_dir
        .join(format!("embree{}", found.major))
        .join("rtcore_config.h");
    fs::read_to_string(config)
        .ok()
        .and_then(|text| {
            text.lines()
                .find_map(|l| l.trim().strip_prefix("#define RTC_VERSION_STRING"))
                .map(|v| v.trim().trim_matches('"').to_string())
        })
        .unwrap_or_else(|| format!("{}.x", found.major))
}

fn is_system_dir(dir: &Path) -> bool {
    default_lib_dirs().iter().any(|d| d == dir)
}

const DRACO_HINT: &str = "strata needs Google's Draco library (headers and library) for \
KHR_draco_mesh_compression. Install it: Debian / Ubuntu: `apt-get install libdraco-dev`; \
Homebrew: `brew install draco`; or set DRACO_DIR to a prefix containing \
include/draco/compression/decode.h and lib/libdraco.so (or libdraco.a).";

/// Builds `src/scene/draco/shim.cc`, the C interface to Draco's decoder, and links Draco:
/// from `DRACO_DIR` (a prefix) or pkg-config's `draco`.
fn draco_shim() {
    println!("cargo::rerun-if-changed=src/scene/draco/shim.cc");
    println!("cargo::rerun-if-env-changed=DRACO_DIR");
    let (includes, lib_dirs): (Vec<PathBuf>, Vec<PathBuf>) =
        match env::var_os("DRACO_DIR").filter(|d| !d.is_empty()) {
            Some(dir) => {
                let dir = PathBuf::from(dir);
                let lib = [
                    "lib",
                    "lib64",
                    "lib/x86_64-linux-gnu",
                    "lib/aarch64-linux-gnu",
                ]
                .iter()
                .map(|d| dir.join(d))
                .find(|d| d.join("libdraco.so").exists() || d.join("libdraco.a").exists())
                .unwrap_or_else(|| dir.join("lib"));
                (vec![dir.join("include")], vec![lib])
            }
            None => match pkg_config::Config::new()
                .cargo_metadata(false)
                .probe("draco")
            {
                Ok(lib) => (lib.include_paths, lib.link_paths),
                Err(e) => {
                    let why = format!("Draco not found by pkg-config ({e}).");
                    eprintln!("error: {why} {DRACO_HINT}");
                    println!("cargo::error={why} {DRACO_HINT}");
                    std::process::exit(1);
                }
            },
        };
    if !includes
        .iter()
        .chain(default_include_dirs().iter())
        .any(|d| d.join("draco/compression/decode.h").exists())
    {
        let why = "Draco's header draco/compression/decode.h not found.";
        eprintln!("error: {why} {DRACO_HINT}");
        println!("cargo::error={why} {DRACO_HINT}");
        std::process::exit(1);
    }
    // The shim first: it needs Draco, so Draco comes after it on the link line.
    cc::Build::new()
        .cpp(true)
        .std("c++17")
        .file("src/scene/draco/shim.cc")
        .includes(&includes)
        .warnings(true)
        .compile("strata_draco_shim");
    for dir in &lib_dirs {
        println!("cargo::rustc-link-search=native={}", dir.display());
        if !is_system_dir(dir) {
            println!("cargo::rustc-link-arg=-Wl,-rpath,{}", dir.display());
        }
    }
    println!("cargo::rustc-link-lib=draco");
}

/// The commit strata is built from, for the EXR header (`strata:commit`): `git rev-parse HEAD`,
/// or "unknown" outside a git checkout. Rebuilt when HEAD moves (its file, and the branch's
/// ref or the packed refs).
fn build_commit() {
    let git = |args: &[&str]| {
        std::process::Command::new("git")
            .args(args)
            .output()
            .ok()
            .filter(|o| o.status.success())
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
    };
    let commit = git(&["rev-parse", "HEAD"]).unwrap_or_else(|| "unknown".into());
    if let (Some(dir), Some(common)) = (
        git(&["rev-parse", "--git-dir"]),
        git(&["rev-parse", "--git-common-dir"]),
    ) {
        println!("cargo::rerun-if-changed={dir}/HEAD");
        let branch = git(&["symbolic-ref", "-q", "HEAD"]).map(|r| PathBuf::from(&common).join(r));
        match branch.filter(|r| r.is_file()) {
            Some(r) => println!("cargo::rerun-if-changed={}", r.display()),
            None if Path::new(&common).join("packed-refs").is_file() => {
                println!("cargo::rerun-if-changed={common}/packed-refs")
            }
            None => {}
        }
    }
    println!("cargo::rustc-env=STRATA_COMMIT={commit}");
}

fn main() {
    build_commit();
    draco_shim();
    println!("cargo::rustc-check-cfg=cfg(embree3)");
    println!("cargo::rustc-check-cfg=cfg(embree4)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=EMBREE_DIR");
    println!("cargo::rerun-if-env-changed=STRATA_EMBREE_VERSION");
    println!("cargo::rerun-if-env-changed=PKG_CONFIG_PATH");

    let found = match find_embree() {
        Ok(f) => f,
        Err(why) => {
            eprintln!("error: {why} {INSTALL_HINT}");
            println!("cargo::error={why} {INSTALL_HINT}");
            std::process::exit(1);
        }
    };
    let version = header_version(&found);
    let header = header_in(&found.include_dir, found.major);
    println!("cargo::rerun-if-changed={}", header.display());
    println!(
        "cargo::warning=strata: using Embree {version} ({}; header {})",
        found.how,
        header.display()
    );

    println!("cargo::rustc-cfg=embree{}", found.major);
    println!("cargo::rustc-env=STRATA_EMBREE_HEADER_VERSION={version}");
    if let Some(dir) = &found.lib_dir {
        println!("cargo::rustc-link-search=native={}", dir.display());
        // A private prefix (EMBREE_DIR) is not on the loader's path: record it in the binaries.
        if !is_system_dir(dir) {
            println!("cargo::rustc-link-arg=-Wl,-rpath,{}", dir.display());
        }
    }
    println!("cargo::rustc-link-lib=dylib={}", lib_name(found.major));

    let bindings = bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", found.include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .derive_default(true)
        .layout_tests(true)
        .generate_comments(false)
        .generate()
        .unwrap_or_else(|e| {
            eprintln!(
                "error: bindgen failed on {} ({e}). bindgen needs libclang: Debian: `apt-get install libclang-dev`.",
                header.display()
            );
            std::process::exit(1);
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings
        .write_to_file(out.join("embree_bindings.rs"))
        .expect("writing the Embree bindings into OUT_DIR");
}
