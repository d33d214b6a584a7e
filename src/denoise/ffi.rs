//! The calls into Open Image Denoise (through the `oidn` crate's raw bindings): a CPU device,
//! and `RT` filters over shared host images. A filter given an auxiliary image (`albedo` or
//! `normal`) and an output but no colour denoises that image itself: the prefilter.

use std::ffi::{c_char, c_void, CStr};

use oidn::sys;

use super::{DenoiseError, Inputs, Options};

/// An OIDN CPU device, released on drop.
struct Device(sys::OIDNDevice);

impl Device {
    fn new(threads: usize) -> Result<Device, DenoiseError> {
        // SAFETY: oidnNewDevice has no preconditions; a null handle is checked below.
        let raw = unsafe { sys::oidnNewDevice(sys::OIDNDeviceType_OIDN_DEVICE_TYPE_CPU) };
        if raw.is_null() {
            return Err(DenoiseError(
                "Open Image Denoise could not create its CPU device (its device module libOpenImageDenoise_device_cpu is missing beside libOpenImageDenoise?)".into(),
            ));
        }
        let device = Device(raw);
        let threads = i32::try_from(threads).unwrap_or(i32::MAX);
        // SAFETY: the handle is a live device not yet committed; the name is a C string.
        unsafe {
            sys::oidnSetDeviceInt(device.0, c"numThreads".as_ptr(), threads);
            sys::oidnCommitDevice(device.0);
        }
        device.check("creating the CPU device")?;
        Ok(device)
    }

    /// The device's pending error, if any, with OIDN's message.
    fn check(&self, doing: &str) -> Result<(), DenoiseError> {
        let mut message: *const c_char = std::ptr::null();
        // SAFETY: a live device; OIDN writes a pointer to a string it owns (valid until
        // the next call on the device) or leaves it null.
        let code = unsafe { sys::oidnGetDeviceError(self.0, &mut message) };
        if code == sys::OIDNError_OIDN_ERROR_NONE {
            return Ok(());
        }
        let text = if message.is_null() {
            String::from("no message")
        } else {
            // SAFETY: non-null, NUL-terminated, owned by the device and not yet reused.
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        Err(DenoiseError(format!(
            "Open Image Denoise failed {doing} (error {code}): {text}"
        )))
    }

    fn version(&self) -> i32 {
        // SAFETY: a live, committed device; "version" is a documented read-only parameter.
        unsafe { sys::oidnGetDeviceInt(self.0, c"version".as_ptr()) }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: the handle is live and released once; filters made on it are released
        // before (they live in `run`'s scope).
        unsafe { sys::oidnReleaseDevice(self.0) }
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
    // SAFETY: a live device; "RT" is a filter type every OIDN 2 build has.
    let filter = unsafe { sys::oidnNewFilter(device.0, c"RT".as_ptr()) };
    device.check("creating the RT filter")?;
    if filter.is_null() {
        return Err(DenoiseError(
            "Open Image Denoise returned no RT filter".into(),
        ));
    }
    struct Filter(sys::OIDNFilter);
    impl Drop for Filter {
        fn drop(&mut self) {
            // SAFETY: the filter is live and released once, after its last execution.
            unsafe { sys::oidnReleaseFilter(self.0) }
        }
    }
    let filter = Filter(filter);
    let format = sys::OIDNFormat_OIDN_FORMAT_FLOAT3;
    for (name, data) in images {
        // SAFETY: `data` holds width × height × 3 floats (checked by `denoise`) and
        // outlives the filter's execution below; OIDN only reads input images, so the
        // cast from a shared pointer is sound.
        unsafe {
            sys::oidnSetSharedFilterImage(
                filter.0,
                name.as_ptr(),
                data.as_ptr() as *mut c_void,
                format,
                width,
                height,
                0,
                0,
                0,
            );
        }
    }
    // SAFETY: as above; `output` is a distinct, writable buffer of the same size, borrowed
    // mutably for the whole execution.
    unsafe {
        sys::oidnSetSharedFilterImage(
            filter.0,
            c"output".as_ptr(),
            output.as_mut_ptr() as *mut c_void,
            format,
            width,
            height,
            0,
            0,
            0,
        );
        sys::oidnSetFilterBool(filter.0, c"hdr".as_ptr(), hdr);
        sys::oidnSetFilterBool(filter.0, c"cleanAux".as_ptr(), clean_aux);
        sys::oidnSetFilterInt(
            filter.0,
            c"quality".as_ptr(),
            sys::OIDNQuality_OIDN_QUALITY_HIGH,
        );
        sys::oidnCommitFilter(filter.0);
    }
    device.check("setting up the filter")?;
    // SAFETY: a committed filter whose images all outlive this synchronous call.
    unsafe { sys::oidnExecuteFilter(filter.0) };
    device.check("denoising")
}

pub(super) fn denoise(inputs: &Inputs, options: &Options) -> Result<Vec<f32>, DenoiseError> {
    let device = Device::new(options.threads)?;
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

pub(super) fn version() -> Option<String> {
    let device = Device::new(1).ok()?;
    let v = device.version();
    Some(format!("{}.{}.{}", v / 10000, v / 100 % 100, v % 100))
}
