//! The calls into Open Image Denoise 2, loaded at run time with `libloading`: a CPU device,
//! and `RT` filters over shared host images. A filter given an auxiliary image (`albedo` or
//! `normal`) and an output but no colour denoises that image itself: the prefilter.
//!
//! The library is looked for once per process ([`library`]), in the order [`candidates`]
//! gives, and kept loaded until the process ends. Only the thirteen functions strata calls
//! are declared, with the prototypes of OIDN 2's `include/OpenImageDenoise/oidn.h`.

use std::ffi::{c_char, c_int, c_void, CStr, OsStr};
use std::mem::ManuallyDrop;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use libloading::Library;

use super::{DenoiseError, Inputs, Options};

/// `OIDNDevice` and `OIDNFilter`: pointers to structs the library keeps to itself.
type RawDevice = *mut c_void;
type RawFilter = *mut c_void;

// oidn.h's enums are plain C enums, passed as `int`. The values strata uses:
/// `OIDN_DEVICE_TYPE_CPU` of `OIDNDeviceType`.
const DEVICE_TYPE_CPU: c_int = 1;
/// `OIDN_FORMAT_FLOAT3` of `OIDNFormat` (FLOAT is 1, FLOAT2 2, FLOAT3 3).
const FORMAT_FLOAT3: c_int = 3;
/// `OIDN_QUALITY_HIGH` of `OIDNQuality` (DEFAULT 0, BALANCED 5, HIGH 6).
const QUALITY_HIGH: c_int = 6;
/// `OIDN_ERROR_NONE` of `OIDNError`.
const ERROR_NONE: c_int = 0;

/// The library's file name by its OIDN 2 soname, and the unversioned development name.
const SONAME: &str = "libOpenImageDenoise.so.2";
const DEV_NAME: &str = "libOpenImageDenoise.so";
/// Where `tools/oidn-prefix.sh` puts the libraries by default, under `$HOME`.
const DEFAULT_PREFIX: &str = ".cache/strata/oidn-2.5.1";

/// The entry points strata calls, each with its C prototype from oidn.h.
struct Api {
    /// `OIDNDevice oidnNewDevice(OIDNDeviceType type)`
    new_device: unsafe extern "C" fn(c_int) -> RawDevice,
    /// `void oidnSetDeviceInt(OIDNDevice device, const char* name, int value)`
    set_device_int: unsafe extern "C" fn(RawDevice, *const c_char, c_int),
    /// `void oidnCommitDevice(OIDNDevice device)`
    commit_device: unsafe extern "C" fn(RawDevice),
    /// `OIDNError oidnGetDeviceError(OIDNDevice device, const char** outMessage)`
    get_device_error: unsafe extern "C" fn(RawDevice, *mut *const c_char) -> c_int,
    /// `int oidnGetDeviceInt(OIDNDevice device, const char* name)`
    get_device_int: unsafe extern "C" fn(RawDevice, *const c_char) -> c_int,
    /// `void oidnReleaseDevice(OIDNDevice device)`
    release_device: unsafe extern "C" fn(RawDevice),
    /// `OIDNFilter oidnNewFilter(OIDNDevice device, const char* type)`
    new_filter: unsafe extern "C" fn(RawDevice, *const c_char) -> RawFilter,
    /// `void oidnSetSharedFilterImage(OIDNFilter filter, const char* name, void* devPtr,
    /// OIDNFormat format, size_t width, size_t height, size_t byteOffset,
    /// size_t pixelByteStride, size_t rowByteStride)`
    #[allow(clippy::type_complexity)]
    set_shared_filter_image: unsafe extern "C" fn(
        RawFilter,
        *const c_char,
        *mut c_void,
        c_int,
        usize,
        usize,
        usize,
        usize,
        usize,
    ),
    /// `void oidnSetFilterBool(OIDNFilter filter, const char* name, bool value)`
    set_filter_bool: unsafe extern "C" fn(RawFilter, *const c_char, bool),
    /// `void oidnSetFilterInt(OIDNFilter filter, const char* name, int value)`
    set_filter_int: unsafe extern "C" fn(RawFilter, *const c_char, c_int),
    /// `void oidnCommitFilter(OIDNFilter filter)`
    commit_filter: unsafe extern "C" fn(RawFilter),
    /// `void oidnExecuteFilter(OIDNFilter filter)`
    execute_filter: unsafe extern "C" fn(RawFilter),
    /// `void oidnReleaseFilter(OIDNFilter filter)`
    release_filter: unsafe extern "C" fn(RawFilter),
}

/// A loaded library and its entry points.
pub(super) struct Oidn {
    api: Api,
    /// "2.5.1", as the library reports it.
    pub(super) version: String,
    /// Never unloaded, so that `api` stays valid, and because the worker threads a device
    /// starts (oneTBB's) may outlive it; the one [`library`] keeps lives until the process
    /// ends anyway.
    _library: ManuallyDrop<Library>,
}

/// One place to look for the library.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Candidate {
    /// A file; `why` says where the path came from ("OIDN_DIR", "the default prefix").
    File { path: PathBuf, why: &'static str },
    /// A bare file name, for the dynamic loader's own search (LD_LIBRARY_PATH, ldconfig).
    Loader(&'static str),
}

/// Where to look, in order, given `OIDN_DIR` and `HOME` as the process has them.
fn candidates(oidn_dir: Option<&OsStr>, home: Option<&OsStr>) -> Vec<Candidate> {
    let mut out = Vec::new();
    if let Some(dir) = oidn_dir.filter(|d| !d.is_empty()) {
        out.push(Candidate::File {
            path: Path::new(dir).join("lib").join(SONAME),
            why: "OIDN_DIR",
        });
    }
    if let Some(home) = home.filter(|h| !h.is_empty()) {
        out.push(Candidate::File {
            path: Path::new(home)
                .join(DEFAULT_PREFIX)
                .join("lib")
                .join(SONAME),
            why: "the default prefix",
        });
    }
    out.push(Candidate::Loader(SONAME));
    out.push(Candidate::Loader(DEV_NAME));
    out
}

/// The library, loaded and checked once per process; the error says why there is none.
pub(super) fn library() -> Result<&'static Oidn, DenoiseError> {
    static LIBRARY: OnceLock<Result<Oidn, String>> = OnceLock::new();
    LIBRARY
        .get_or_init(|| {
            let oidn_dir = std::env::var_os("OIDN_DIR");
            let home = std::env::var_os("HOME");
            load(&candidates(oidn_dir.as_deref(), home.as_deref())).map_err(|e| e.0)
        })
        .as_ref()
        .map_err(|e| DenoiseError(e.clone()))
}

/// What to do about a library that is missing or unusable.
const REMEDY: &str = "run `tools/oidn-prefix.sh` from strata's repository (it fetches the libraries of PyPI's pyoidn wheel into ~/.cache/strata/oidn-2.5.1, where strata looks), or set OIDN_DIR to an Open Image Denoise 2 prefix (README, \"Denoising\")";

/// The message when no candidate held a library: what was looked for, where, and the fix.
fn not_found(looked: &[Candidate]) -> String {
    let mut places: Vec<String> = Vec::new();
    let mut names: Vec<&str> = Vec::new();
    for c in looked {
        match c {
            Candidate::File { path, why } => places.push(format!("{} ({why})", path.display())),
            Candidate::Loader(name) => names.push(name),
        }
    }
    if !names.is_empty() {
        places.push(format!(
            "{} on the loader's search path",
            names.join(" and ")
        ));
    }
    format!(
        "denoising needs Intel Open Image Denoise 2, which was not found (looked for {}): {REMEDY}",
        places.join(", then ")
    )
}

/// Loads the first candidate present. A file that is absent, or a name the loader does not
/// find, passes to the next; one that is there but unusable is an error naming it.
fn load(candidates: &[Candidate]) -> Result<Oidn, DenoiseError> {
    for candidate in candidates {
        let (library, source) = match candidate {
            Candidate::File { path, why } => {
                if !path.exists() {
                    continue;
                }
                let source = format!("{} ({why})", path.display());
                // SAFETY: loading runs the library's initialisers; an OIDN build's (and its
                // oneTBB's) set up their own state only. The path is a file we were pointed
                // at as Open Image Denoise; what it exports is checked before any call.
                match unsafe { Library::new(path) } {
                    Ok(l) => (l, source),
                    Err(e) => {
                        return Err(DenoiseError(format!(
                            "{source} cannot be loaded: {e}; {REMEDY}"
                        )))
                    }
                }
            }
            Candidate::Loader(name) => {
                // SAFETY: as above, for the file the loader finds by this name.
                match unsafe { Library::new(name) } {
                    Ok(l) => (l, format!("{name} (from the loader's search path)")),
                    // The loader says "NAME: cannot open shared object file" when it has no
                    // such file; anything else is a library found and refused.
                    Err(e) if loader_lacks(&e.to_string(), name) => continue,
                    Err(e) => {
                        return Err(DenoiseError(format!(
                            "{name} (from the loader's search path) cannot be loaded: {e}; {REMEDY}"
                        )))
                    }
                }
            }
        };
        return open(library, source);
    }
    Err(DenoiseError(not_found(candidates)))
}

/// Whether a loader error says only that the file `name` is nowhere on its path.
fn loader_lacks(error: &str, name: &str) -> bool {
    error.contains(&format!("{name}: cannot open shared object file"))
}

/// Reads the entry points of a loaded library and asks a device for its version.
fn open(library: Library, source: String) -> Result<Oidn, DenoiseError> {
    let unusable = |what: String| DenoiseError(format!("{source} {what}; {REMEDY}"));
    let missing = |name: &str| {
        // SAFETY: only whether the symbol exists is asked; it is never called.
        let oidn1 = unsafe { library.get::<*const c_void>(b"oidnSetDevice1i\0") }.is_ok();
        unusable(match oidn1 {
            true => format!("is Open Image Denoise 1 (it has oidnSetDevice1i, not {name}); strata needs version 2"),
            false => format!("is not an Open Image Denoise 2 library: it lacks the function {name}"),
        })
    };
    macro_rules! entry {
        ($name:literal) => {
            // SAFETY: the symbol is read into the `Api` field of the same name, whose type
            // is the prototype oidn.h (OIDN 2) declares for it; the pointer is used only
            // while `library` lives, which `Oidn` guarantees by owning it.
            match unsafe { library.get(concat!($name, "\0").as_bytes()) } {
                Ok(symbol) => *symbol,
                Err(_) => return Err(missing($name)),
            }
        };
    }
    let api = Api {
        new_device: entry!("oidnNewDevice"),
        set_device_int: entry!("oidnSetDeviceInt"),
        commit_device: entry!("oidnCommitDevice"),
        get_device_error: entry!("oidnGetDeviceError"),
        get_device_int: entry!("oidnGetDeviceInt"),
        release_device: entry!("oidnReleaseDevice"),
        new_filter: entry!("oidnNewFilter"),
        set_shared_filter_image: entry!("oidnSetSharedFilterImage"),
        set_filter_bool: entry!("oidnSetFilterBool"),
        set_filter_int: entry!("oidnSetFilterInt"),
        commit_filter: entry!("oidnCommitFilter"),
        execute_filter: entry!("oidnExecuteFilter"),
        release_filter: entry!("oidnReleaseFilter"),
    };
    let mut oidn = Oidn {
        api,
        version: String::new(),
        _library: ManuallyDrop::new(library),
    };
    let v = {
        let device = Device::new(&oidn, 1).map_err(|e| unusable(format!("is unusable: {e}")))?;
        device.int(c"version")
    };
    let (major, minor, patch) = (v / 10000, v / 100 % 100, v % 100);
    if major != 2 {
        return Err(unusable(format!(
            "reports version {major}.{minor}.{patch} ({v}); strata needs Open Image Denoise 2"
        )));
    }
    oidn.version = format!("{major}.{minor}.{patch}");
    Ok(oidn)
}

/// An OIDN CPU device, released on drop.
struct Device<'a> {
    oidn: &'a Oidn,
    raw: RawDevice,
}

impl<'a> Device<'a> {
    fn new(oidn: &'a Oidn, threads: usize) -> Result<Device<'a>, DenoiseError> {
        let api = &oidn.api;
        // SAFETY: oidnNewDevice takes a device type and has no other precondition; a null
        // handle is checked below.
        let raw = unsafe { (api.new_device)(DEVICE_TYPE_CPU) };
        if raw.is_null() {
            // A device that could not be made leaves its error on the null device.
            let why = error(api, std::ptr::null_mut())
                .map(|(code, text)| format!(" (error {code}: {text})"))
                .unwrap_or_default();
            return Err(DenoiseError(format!(
                "Open Image Denoise could not create its CPU device{why}: its module libOpenImageDenoise_device_cpu should sit beside libOpenImageDenoise"
            )));
        }
        let device = Device { oidn, raw };
        let threads = c_int::try_from(threads).unwrap_or(c_int::MAX);
        // SAFETY: a live device not yet committed; the name is a NUL-terminated string.
        unsafe {
            (api.set_device_int)(device.raw, c"numThreads".as_ptr(), threads);
            (api.commit_device)(device.raw);
        }
        device.check("creating the CPU device")?;
        Ok(device)
    }

    /// The device's pending error, if any, with OIDN's message.
    fn check(&self, doing: &str) -> Result<(), DenoiseError> {
        match error(&self.oidn.api, self.raw) {
            None => Ok(()),
            Some((code, text)) => Err(DenoiseError(format!(
                "Open Image Denoise failed {doing} (error {code}): {text}"
            ))),
        }
    }

    /// A device parameter read as an integer ("version").
    fn int(&self, name: &CStr) -> i32 {
        // SAFETY: a live, committed device and a NUL-terminated parameter name; an unknown
        // name is reported through the device's error, not undefined behaviour.
        unsafe { (self.oidn.api.get_device_int)(self.raw, name.as_ptr()) }
    }
}

/// The pending error of `device` (or the process-wide one, for a null device), cleared.
fn error(api: &Api, device: RawDevice) -> Option<(c_int, String)> {
    let mut message: *const c_char = std::ptr::null();
    // SAFETY: `device` is live or null (which oidn.h allows, for errors of device creation);
    // OIDN writes a pointer to a string it owns, valid until its next call, or leaves null.
    let code = unsafe { (api.get_device_error)(device, &mut message) };
    if code == ERROR_NONE {
        return None;
    }
    let text = if message.is_null() {
        String::from("no message")
    } else {
        // SAFETY: non-null, NUL-terminated, owned by OIDN and not yet reused.
        unsafe { CStr::from_ptr(message) }
            .to_string_lossy()
            .into_owned()
    };
    Some((code, text))
}

impl Drop for Device<'_> {
    fn drop(&mut self) {
        // SAFETY: the handle is live and released once; filters made on it are released
        // before (they live in `run`'s scope, which borrows the device).
        unsafe { (self.oidn.api.release_device)(self.raw) }
    }
}

/// A filter, released on drop.
struct Filter<'a> {
    api: &'a Api,
    raw: RawFilter,
}

impl Drop for Filter<'_> {
    fn drop(&mut self) {
        // SAFETY: the filter is live and released once, after its last execution.
        unsafe { (self.api.release_filter)(self.raw) }
    }
}

/// Runs one `RT` filter over shared host images: `images` by name (`color`, `albedo`,
/// `normal`), the result into `output`.
fn run(
    device: &Device,
    (width, height): (usize, usize),
    images: &[(&CStr, &[f32])],
    output: &mut [f32],
    hdr: bool,
    clean_aux: bool,
) -> Result<(), DenoiseError> {
    let api = &device.oidn.api;
    // SAFETY: a live, committed device; "RT" is a filter type every OIDN 2 build has.
    let raw = unsafe { (api.new_filter)(device.raw, c"RT".as_ptr()) };
    device.check("creating the RT filter")?;
    if raw.is_null() {
        return Err(DenoiseError(
            "Open Image Denoise returned no RT filter".into(),
        ));
    }
    let filter = Filter { api, raw };
    for (name, data) in images {
        // SAFETY: `data` holds width × height × 3 floats (checked by `denoise`) and
        // outlives the filter's execution below; OIDN only reads input images, so the
        // cast from a shared pointer is sound. Zero strides mean tightly packed.
        unsafe {
            (api.set_shared_filter_image)(
                filter.raw,
                name.as_ptr(),
                data.as_ptr() as *mut c_void,
                FORMAT_FLOAT3,
                width,
                height,
                0,
                0,
                0,
            );
        }
    }
    // SAFETY: as above; `output` is a distinct, writable buffer of the same size, borrowed
    // mutably for the whole execution. The parameter names are NUL-terminated.
    unsafe {
        (api.set_shared_filter_image)(
            filter.raw,
            c"output".as_ptr(),
            output.as_mut_ptr() as *mut c_void,
            FORMAT_FLOAT3,
            width,
            height,
            0,
            0,
            0,
        );
        (api.set_filter_bool)(filter.raw, c"hdr".as_ptr(), hdr);
        (api.set_filter_bool)(filter.raw, c"cleanAux".as_ptr(), clean_aux);
        (api.set_filter_int)(filter.raw, c"quality".as_ptr(), QUALITY_HIGH);
        (api.commit_filter)(filter.raw);
    }
    device.check("setting up the filter")?;
    // SAFETY: a committed filter whose images all outlive this synchronous call.
    unsafe { (api.execute_filter)(filter.raw) };
    device.check("denoising")
}

pub(super) fn denoise(inputs: &Inputs, options: &Options) -> Result<Vec<f32>, DenoiseError> {
    let device = Device::new(library()?, options.threads)?;
    let dims = (inputs.width, inputs.height);
    let n = inputs.color.len();
    // Prefiltered auxiliary images, when asked for.
    let mut clean: [Option<Vec<f32>>; 2] = [None, None];
    if options.prefilter {
        for (slot, (name, image)) in [(c"albedo", inputs.albedo), (c"normal", inputs.normal)]
            .into_iter()
            .enumerate()
        {
            if let Some(image) = image {
                let mut out = vec![0f32; n];
                run(&device, dims, &[(name, image)], &mut out, false, false)?;
                clean[slot] = Some(out);
            }
        }
    }
    let albedo = clean[0].as_deref().or(inputs.albedo);
    let normal = clean[1].as_deref().or(inputs.normal);
    let mut images: Vec<(&CStr, &[f32])> = vec![(c"color", inputs.color)];
    images.extend(albedo.map(|a| (c"albedo", a)));
    images.extend(normal.map(|nm| (c"normal", nm)));
    let mut out = vec![0f32; n];
    let clean_aux = options.prefilter && albedo.is_some();
    run(&device, dims, &images, &mut out, true, clean_aux)?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(path: &str, why: &'static str) -> Candidate {
        Candidate::File {
            path: PathBuf::from(path),
            why,
        }
    }

    #[test]
    fn the_places_are_oidn_dir_then_the_default_prefix_then_the_loader() {
        let both = candidates(Some(OsStr::new("/opt/oidn")), Some(OsStr::new("/home/ann")));
        assert_eq!(
            both,
            vec![
                file("/opt/oidn/lib/libOpenImageDenoise.so.2", "OIDN_DIR"),
                file(
                    "/home/ann/.cache/strata/oidn-2.5.1/lib/libOpenImageDenoise.so.2",
                    "the default prefix"
                ),
                Candidate::Loader("libOpenImageDenoise.so.2"),
                Candidate::Loader("libOpenImageDenoise.so"),
            ]
        );
        // An empty OIDN_DIR is no OIDN_DIR; no HOME, no default prefix.
        let neither = candidates(Some(OsStr::new("")), None);
        assert_eq!(
            neither,
            vec![
                Candidate::Loader("libOpenImageDenoise.so.2"),
                Candidate::Loader("libOpenImageDenoise.so"),
            ]
        );
    }

    #[test]
    fn absent_files_are_passed_over_and_the_message_names_every_place() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a/lib/libOpenImageDenoise.so.2");
        let b = dir.path().join("b/lib/libOpenImageDenoise.so.2");
        let looked = [
            Candidate::File {
                path: a.clone(),
                why: "OIDN_DIR",
            },
            Candidate::File {
                path: b.clone(),
                why: "the default prefix",
            },
        ];
        let Err(e) = load(&looked) else {
            panic!("nothing was there to load")
        };
        let text = e.to_string();
        for needle in [
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "tools/oidn-prefix.sh",
            "OIDN_DIR",
            "Open Image Denoise 2",
        ] {
            assert!(text.contains(needle), "{needle:?} missing from: {text}");
        }
        assert!(!text.contains('\n'), "one line: {text}");

        // Past an absent file the search reaches the next one: here a file that is there
        // but no library, which is then named.
        let c = dir.path().join("c/lib/libOpenImageDenoise.so.2");
        std::fs::create_dir_all(c.parent().unwrap()).unwrap();
        std::fs::write(&c, b"not a library").unwrap();
        let next = [
            looked[0].clone(),
            Candidate::File {
                path: c.clone(),
                why: "the default prefix",
            },
        ];
        let Err(e) = load(&next) else {
            panic!("a text file loaded as a library")
        };
        let text = e.to_string();
        assert!(text.contains(c.to_str().unwrap()), "{text}");
        assert!(text.contains("cannot be loaded"), "{text}");
    }

    #[test]
    fn a_file_that_is_not_a_library_is_named_and_not_passed_over() {
        let dir = tempfile::tempdir().unwrap();
        let lib = dir.path().join("lib");
        std::fs::create_dir_all(&lib).unwrap();
        let bogus = lib.join(SONAME);
        std::fs::write(&bogus, b"not an ELF file").unwrap();
        let after = dir.path().join("never/libOpenImageDenoise.so.2");
        let looked = [
            Candidate::File {
                path: bogus.clone(),
                why: "OIDN_DIR",
            },
            Candidate::File {
                path: after.clone(),
                why: "the default prefix",
            },
        ];
        let Err(e) = load(&looked) else {
            panic!("a text file loaded as a library")
        };
        let text = e.to_string();
        assert!(text.contains(bogus.to_str().unwrap()), "{text}");
        assert!(text.contains("cannot be loaded"), "{text}");
        assert!(
            !text.contains(after.to_str().unwrap()),
            "the search stops at the broken file: {text}"
        );
    }

    #[test]
    fn a_library_without_the_api_is_named_with_the_function_it_lacks() {
        // Any shared library that is not OIDN will do: zlib is on every Debian system.
        let Some(zlib) = [
            "/lib/x86_64-linux-gnu/libz.so.1",
            "/usr/lib/libz.so.1",
            "/lib64/libz.so.1",
        ]
        .iter()
        .map(Path::new)
        .find(|p| p.exists()) else {
            eprintln!("SKIPPED: no libz.so.1 to stand in for a library without OIDN's API");
            return;
        };
        let dir = tempfile::tempdir().unwrap();
        let fake = dir.path().join(SONAME);
        std::fs::copy(zlib, &fake).unwrap();
        let Err(e) = load(&[Candidate::File {
            path: fake.clone(),
            why: "OIDN_DIR",
        }]) else {
            panic!("zlib passed for Open Image Denoise")
        };
        let text = e.to_string();
        assert!(text.contains(fake.to_str().unwrap()), "{text}");
        assert!(text.contains("lacks the function oidnNewDevice"), "{text}");
        assert!(text.contains("tools/oidn-prefix.sh"), "{text}");
    }

    #[test]
    fn the_loaders_not_found_message_is_recognised() {
        // The loader's own words for a name it cannot find, which `load` relies on.
        let name = "libstrata-test-no-such-library.so.7";
        // SAFETY: no such file exists, so nothing is loaded or run.
        let e = unsafe { Library::new(name) }.expect_err("no such library");
        assert!(loader_lacks(&e.to_string(), name), "{e}");
        // A library found whose dependency is missing is not "not found".
        let dependency =
            "libOpenImageDenoise.so.2: libtbb.so.12: cannot open shared object file: No such file or directory";
        assert!(!loader_lacks(dependency, SONAME));
        assert!(loader_lacks(
            "libOpenImageDenoise.so.2: cannot open shared object file: No such file or directory",
            SONAME
        ));
    }
}
