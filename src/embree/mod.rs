//! A small safe wrapper over Intel Embree (3.13 or 4.x): with `crate::denoise`'s FFI module,
//! the only place in strata with `unsafe`.
//!
//! `build.rs` generates the raw bindings (module [`sys`]) from whichever header it found and sets
//! `cfg(embree3)` or `cfg(embree4)`. The differences between the two APIs (the intersection
//! context of Embree 3 versus the optional argument structs of Embree 4, ray masks enabled by
//! default in Embree 4) stay inside this file: callers see [`Device`], [`SceneBuilder`] and the
//! committed, thread-safe [`Scene`] with [`Scene::intersect`] and [`Scene::occluded`].
//!
//! Hit filters: a geometry attached with a [`HitFilter`] has it run on every candidate hit of
//! every query (single rays and packets, closest and any hit) through Embree's geometry
//! filter callbacks (`rtcSetGeometryIntersectFilterFunction`,
//! `rtcSetGeometryOccludedFilterFunction`), which reject a hit by clearing its `valid` lane.
//! Embree 3 runs them whenever they are set. Embree 4 runs a geometry's own filter when the
//! query's feature mask holds `RTC_FEATURE_FLAG_FILTER_FUNCTION_IN_GEOMETRY`: the default
//! mask (`RTC_FEATURE_FLAG_ALL`, what null arguments select) and the one
//! `intersect_arguments` sets both do. (Embree 4's other filter, the one passed in
//! `RTCIntersectArguments::filter`, needs `RTC_SCENE_FLAG_FILTER_FUNCTION_IN_ARGUMENTS` and
//! `rtcSetGeometryEnableFilterFunctionFromArguments`; strata does not use it.) Geometry
//! without a filter pays nothing.
//!
//! Device errors reported through the error callback or `rtcGetDeviceError` become
//! [`EmbreeError`]s; nothing is ignored.

use std::any::Any;
use std::ffi::{c_char, c_void, CStr, CString};
use std::fmt;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::{Arc, Mutex};

#[allow(
    non_camel_case_types,
    non_snake_case,
    non_upper_case_globals,
    dead_code,
    unused_imports,
    clippy::all,
    clippy::pedantic,
    unsafe_op_in_unsafe_fn
)]
pub mod sys {
    include!(concat!(env!("OUT_DIR"), "/embree_bindings.rs"));
}

/// The Embree major version strata was compiled against.
#[cfg(embree4)]
pub const MAJOR: u32 = 4;
/// The Embree major version strata was compiled against.
#[cfg(embree3)]
pub const MAJOR: u32 = 3;

/// `RTC_INVALID_GEOMETRY_ID` is a macro (`(unsigned int)-1`) that bindgen does not translate.
pub const INVALID_GEOMETRY_ID: u32 = u32::MAX;

/// An error reported by Embree.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct EmbreeError {
    pub code: u32,
    pub message: String,
}

impl EmbreeError {
    /// An error Embree did not report itself: `RTC_ERROR_UNKNOWN` with `message`.
    pub fn unknown(message: String) -> EmbreeError {
        EmbreeError {
            code: sys::RTC_ERROR_UNKNOWN,
            message,
        }
    }
}

impl fmt::Display for EmbreeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "Embree error {} ({})",
            error_name(self.code),
            self.message
        )
    }
}

impl std::error::Error for EmbreeError {}

fn error_name(code: u32) -> &'static str {
    match code {
        sys::RTC_ERROR_NONE => "RTC_ERROR_NONE",
        sys::RTC_ERROR_UNKNOWN => "RTC_ERROR_UNKNOWN",
        sys::RTC_ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT",
        sys::RTC_ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION",
        sys::RTC_ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY",
        sys::RTC_ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU",
        sys::RTC_ERROR_CANCELLED => "RTC_ERROR_CANCELLED",
        _ => "unrecognised error code",
    }
}

/// Sets flush-to-zero and denormals-are-zero in this thread's MXCSR, as Embree's documentation
/// asks of every thread that traces rays (denormal arithmetic is very slow in traversal).
pub fn enable_ftz_daz() {
    #[cfg(any(target_arch = "x86_64", target_arch = "x86"))]
    {
        const FTZ: u32 = 1 << 15;
        const DAZ: u32 = 1 << 6;
        let mut csr: u32 = 0;
        // SAFETY: stmxcsr/ldmxcsr only read and write this thread's SSE control register through
        // a pointer to a local; setting FTZ and DAZ changes no memory and cannot fault.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack));
            csr |= FTZ | DAZ;
            std::arch::asm!("ldmxcsr [{}]", in(reg) &csr, options(nostack, readonly));
        }
    }
}

/// True when both FTZ and DAZ are set on this thread (for tests).
pub fn ftz_daz_enabled() -> bool {
    #[cfg(any(target_arch = "x86_64", target_arch = "x86"))]
    {
        let mut csr: u32 = 0;
        // SAFETY: stmxcsr writes this thread's MXCSR into a local u32.
        unsafe {
            std::arch::asm!("stmxcsr [{}]", in(reg) &mut csr, options(nostack));
        }
        csr & ((1 << 15) | (1 << 6)) == (1 << 15) | (1 << 6)
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "x86")))]
    {
        true
    }
}

/// Errors collected by the device's error callback until the next [`Device::check`].
type ErrorSlot = Mutex<Option<EmbreeError>>;

struct DeviceInner {
    raw: sys::RTCDevice,
    /// Owned by this struct and handed to Embree as the callback's user pointer.
    errors: *mut ErrorSlot,
    /// Bytes Embree has allocated, kept by the memory monitor callback; owned by this
    /// struct like `errors`.
    memory: *mut MemoryCounter,
}

// SAFETY: an RTCDevice may be used from any thread (Embree's API is thread-safe at the device
// level), and the error slot behind `errors` is a Mutex.
unsafe impl Send for DeviceInner {}
// SAFETY: as above; shared access only reaches Embree calls documented as thread-safe and the
// Mutex-protected error slot.
unsafe impl Sync for DeviceInner {}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: `raw` came from rtcNewDevice and this is the last reference we hold; the error
        // callback is removed before the slot it points to is freed.
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            sys::rtcSetDeviceMemoryMonitorFunction(self.raw, None, std::ptr::null_mut());
            sys::rtcReleaseDevice(self.raw);
            drop(Box::from_raw(self.errors));
            drop(Box::from_raw(self.memory));
        }
    }
}

/// An Embree device: the owner of every scene and geometry made from it.
#[derive(Clone)]
pub struct Device {
    inner: Arc<DeviceInner>,
}

unsafe extern "C" fn error_callback(
    user: *mut c_void,
    code: sys::RTCError,
    message: *const c_char,
) {
    if user.is_null() {
        return;
    }
    // SAFETY: `user` is the `*mut ErrorSlot` registered in Device::new and stays alive until the
    // callback is unregistered in Drop; `message` is a NUL-terminated string or null per Embree.
    let (slot, text) = unsafe {
        let text = if message.is_null() {
            String::new()
        } else {
            CStr::from_ptr(message).to_string_lossy().into_owned()
        };
        (&*(user as *const ErrorSlot), text)
    };
    if let Ok(mut guard) = slot.lock() {
        // Keep the first error: later ones are usually consequences of it.
        guard.get_or_insert(EmbreeError {
            code,
            message: text,
        });
    }
}

/// Bytes allocated and not freed, and the most that ever were at once.
#[derive(Default)]
struct MemoryCounter {
    current: AtomicI64,
    peak: AtomicI64,
}

/// Embree calls this before each allocation it tracks (bytes > 0, `post` false) and after
/// each free (bytes < 0, `post` true); returning true lets the allocation proceed.
unsafe extern "C" fn memory_callback(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    if !user.is_null() {
        // SAFETY: `user` is the `*mut MemoryCounter` registered in Device::new, alive until
        // the callback is unregistered in Drop.
        let counter = unsafe { &*(user as *const MemoryCounter) };
        let now = counter.current.fetch_add(bytes as i64, Ordering::Relaxed) + bytes as i64;
        counter.peak.fetch_max(now, Ordering::Relaxed);
    }
    true
}

impl Device {
    /// Creates a device with the given Embree configuration string (e.g. `"threads=2"`).
    pub fn new(config: &str) -> Result<Device, EmbreeError> {
        let config = CString::new(config).map_err(|_| EmbreeError {
            code: sys::RTC_ERROR_INVALID_ARGUMENT,
            message: "device configuration contains a NUL byte".into(),
        })?;
        // SAFETY: `config` is a valid NUL-terminated string for the duration of the call.
        let raw = unsafe { sys::rtcNewDevice(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError accepts a null device and returns the thread's last
            // device-creation error.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError {
                code,
                message: format!("rtcNewDevice({config:?}) failed"),
            });
        }
        let errors: *mut ErrorSlot = Box::into_raw(Box::new(Mutex::new(None)));
        // SAFETY: `raw` is a live device; `errors` points to a heap slot that outlives the
        // registration (it is unregistered before being freed in DeviceInner::drop).
        unsafe { sys::rtcSetDeviceErrorFunction(raw, Some(error_callback), errors.cast()) };
        let memory: *mut MemoryCounter = Box::into_raw(Box::default());
        // SAFETY: as for the error slot: `memory` outlives its registration.
        unsafe {
            sys::rtcSetDeviceMemoryMonitorFunction(raw, Some(memory_callback), memory.cast())
        };
        Ok(Device {
            inner: Arc::new(DeviceInner {
                raw,
                errors,
                memory,
            }),
        })
    }

    /// Returns and clears the first error Embree reported since the last check.
    pub fn check(&self) -> Result<(), EmbreeError> {
        // SAFETY: `errors` is valid for the lifetime of `inner` (see DeviceInner).
        let slot = unsafe { &*self.inner.errors };
        let reported = slot.lock().ok().and_then(|mut g| g.take());
        // SAFETY: `raw` is a live device.
        let code = unsafe { sys::rtcGetDeviceError(self.inner.raw) };
        match reported {
            Some(e) => Err(e),
            None if code != sys::RTC_ERROR_NONE => Err(EmbreeError {
                code,
                message: "reported by rtcGetDeviceError".into(),
            }),
            None => Ok(()),
        }
    }

    /// Bytes Embree reports as allocated and not yet freed on this device (geometry buffers,
    /// BVH nodes and leaves, builder scratch while a build runs), from its memory monitor.
    pub fn memory_in_use(&self) -> i64 {
        // SAFETY: `memory` is valid for the lifetime of `inner` (see DeviceInner).
        unsafe { &*self.inner.memory }
            .current
            .load(Ordering::Relaxed)
    }

    /// The most bytes [`Device::memory_in_use`] has ever been (a build's peak).
    pub fn peak_memory(&self) -> i64 {
        // SAFETY: as above.
        unsafe { &*self.inner.memory }.peak.load(Ordering::Relaxed)
    }

    /// The version of the Embree library loaded at run time, e.g. `"4.4.0"`.
    pub fn version(&self) -> String {
        // SAFETY: `raw` is a live device; the property is a plain integer query.
        let v =
            unsafe { sys::rtcGetDeviceProperty(self.inner.raw, sys::RTC_DEVICE_PROPERTY_VERSION) };
        format!("{}.{}.{}", v / 10000, (v / 100) % 100, v % 100)
    }
}

/// Decides whether a candidate hit on a geometry counts: registered with
/// [`SceneBuilder::attach_filtered_triangles`] or [`SceneBuilder::attach_filtered_quads`], it
/// runs inside Embree's traversal, from any thread, for every hit the geometry's primitives
/// report to any query. It must not panic: a panic cannot unwind through Embree, and aborts.
pub trait HitFilter: Send + Sync + 'static {
    /// True when the hit of a ray with primitive `prim` of the geometry, at Embree's
    /// coordinates (u, v) (as [`RawHit`] reports them), counts; false rejects it and the
    /// traversal goes on past it. `inst` is the instance the geometry was reached through
    /// ([`INVALID_GEOMETRY_ID`] outside instances) and `ray_id` the id the ray was traced
    /// with ([`Scene::intersect_id`]): the same inside an instance as outside, where Embree
    /// hands the filter the ray in the instance's space.
    fn accept(&self, prim: u32, inst: u32, u: f32, v: f32, ray_id: u32) -> bool;
}

/// Embree's intersection and occlusion filter callback for a geometry whose user data is an
/// `F`: asks `F` about each valid lane of the packet of hits and clears the lanes it rejects.
/// The ray and hit packets are `N` wide, structure of arrays, laid out as `rtcore_ray.h`'s
/// `RTCRayN_*` and `RTCHitN_*` accessors read them (the same in Embree 3 and 4): ray field k
/// of lane i at 4-byte word k·N + i (the id: k = 10), hit u, v at 3·N + i, 4·N + i, primID
/// at 5·N + i, the first level's instID at 7·N + i.
unsafe extern "C" fn filter_hits<F: HitFilter>(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes a valid argument struct for the duration of the call. Its
    // geometryUserPtr is the `F` registered with the geometry in `attach_mesh`, kept alive by
    // the SceneBuilder and then the Scene that own the geometry (released before it); `valid`
    // points to N ints Embree lets the filter write; `ray` and `hit` to N-wide packets.
    let (filter, valid, ray, hit, n) = unsafe {
        let a = &*args;
        let n = a.N as usize;
        if n == 0 || a.valid.is_null() {
            return;
        }
        (
            &*(a.geometryUserPtr as *const F),
            std::slice::from_raw_parts_mut(a.valid, n),
            a.ray as *const f32,
            a.hit as *const f32,
            n,
        )
    };
    for (i, lane) in valid.iter_mut().enumerate() {
        if *lane == 0 {
            continue;
        }
        // SAFETY: i < N, and every offset read lies inside the N-wide packets (see above).
        let (ray_id, u, v, prim, inst) = unsafe {
            (
                *(ray as *const u32).add(10 * n + i),
                *hit.add(3 * n + i),
                *hit.add(4 * n + i),
                *(hit as *const u32).add(5 * n + i),
                *(hit as *const u32).add(7 * n + i),
            )
        };
        if !filter.accept(prim, inst, u, v, ray_id) {
            *lane = 0;
        }
    }
}

/// A [`HitFilter`] ready to register: Embree's callback for its type, its address as the
/// geometry's user pointer, and the owner that keeps it alive.
struct FilterBinding {
    callback: unsafe extern "C" fn(*const sys::RTCFilterFunctionNArguments),
    user: *mut c_void,
    owner: Arc<dyn Any + Send + Sync>,
}

impl FilterBinding {
    fn new<F: HitFilter>(filter: Arc<F>) -> FilterBinding {
        FilterBinding {
            callback: filter_hits::<F>,
            user: Arc::as_ptr(&filter) as *mut c_void,
            owner: filter,
        }
    }
}

/// Scene build quality, mapped to `RTCBuildQuality`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuildQuality {
    Low,
    Medium,
    High,
}

/// Options for building a scene.
#[derive(Clone, Copy, Debug)]
pub struct SceneOptions {
    pub quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: avoids optimisations that trade watertightness for speed.
    pub robust: bool,
    /// `RTC_SCENE_FLAG_COMPACT`: smaller BVH at some traversal cost.
    pub compact: bool,
}

/// A scene under construction: geometry is attached, then [`SceneBuilder::commit`] builds the BVH.
pub struct SceneBuilder {
    device: Device,
    raw: sys::RTCScene,
    quality: BuildQuality,
    /// The hit filters of the attached geometries, alive as long as the scene is.
    filters: Vec<Arc<dyn Any + Send + Sync>>,
    /// The scenes its instances place, alive as long as it is.
    children: Vec<Arc<Scene>>,
}

impl Drop for SceneBuilder {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: `raw` came from rtcNewScene and has not been released (commit nulls it).
            unsafe { sys::rtcReleaseScene(self.raw) };
        }
    }
}

impl SceneBuilder {
    pub fn new(device: &Device, options: SceneOptions) -> Result<SceneBuilder, EmbreeError> {
        // SAFETY: the device is live; a null return is handled below.
        let raw = unsafe { sys::rtcNewScene(device.inner.raw) };
        device.check()?;
        if raw.is_null() {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_UNKNOWN,
                message: "rtcNewScene returned null".into(),
            });
        }
        let mut flags = sys::RTC_SCENE_FLAG_NONE;
        if options.robust {
            flags |= sys::RTC_SCENE_FLAG_ROBUST;
        }
        if options.compact {
            flags |= sys::RTC_SCENE_FLAG_COMPACT;
        }
        let quality = to_quality(options.quality);
        // SAFETY: `raw` is a live, uncommitted scene; flags and quality are valid enum values.
        unsafe {
            sys::rtcSetSceneFlags(raw, flags);
            sys::rtcSetSceneBuildQuality(raw, quality);
        }
        let builder = SceneBuilder {
            device: device.clone(),
            raw,
            quality: options.quality,
            filters: Vec::new(),
            children: Vec::new(),
        };
        device.check()?;
        Ok(builder)
    }

    /// Attaches a triangle mesh; returns its geometry id. Primitive ids of hits are indices
    /// into `indices`. Vertex and index data are copied into buffers Embree allocates (so
    /// its padding requirement for vertex buffers is met).
    pub fn attach_triangles(
        &mut self,
        positions: &[[f32; 3]],
        indices: &[[u32; 3]],
    ) -> Result<u32, EmbreeError> {
        self.attach_mesh(
            positions,
            indices,
            sys::RTC_GEOMETRY_TYPE_TRIANGLE,
            sys::RTC_FORMAT_UINT3,
            None,
        )
    }

    /// [`Self::attach_triangles`] with `filter` deciding which of the mesh's hits count (for
    /// every query; see the module docs). The scene keeps `filter` alive.
    pub fn attach_filtered_triangles<F: HitFilter>(
        &mut self,
        positions: &[[f32; 3]],
        indices: &[[u32; 3]],
        filter: Arc<F>,
    ) -> Result<u32, EmbreeError> {
        self.attach_mesh(
            positions,
            indices,
            sys::RTC_GEOMETRY_TYPE_TRIANGLE,
            sys::RTC_FORMAT_UINT3,
            Some(FilterBinding::new(filter)),
        )
    }

    /// Attaches a quad mesh (vertices v0 v1 v2 v3 in order around the quad); returns its
    /// geometry id. Embree treats each quad as the triangles (v0, v1, v3) and (v2, v3, v1):
    /// a hit on the first reports that triangle's barycentrics as `u`, `v`, one on the second
    /// reports 1 − u′ and 1 − v′ of its barycentrics u′, v′, so that u + v > 1 there (Embree's
    /// `RTC_GEOMETRY_TYPE_QUAD`); `ng` is the normal of the triangle hit, with its winding. A
    /// triangle may be given as a quad with v3 = v2. As [`Self::attach_triangles`] otherwise.
    pub fn attach_quads(
        &mut self,
        positions: &[[f32; 3]],
        indices: &[[u32; 4]],
    ) -> Result<u32, EmbreeError> {
        self.attach_mesh(
            positions,
            indices,
            sys::RTC_GEOMETRY_TYPE_QUAD,
            sys::RTC_FORMAT_UINT4,
            None,
        )
    }

    /// [`Self::attach_quads`] with `filter` deciding which of the mesh's hits count; it is
    /// given Embree's quad coordinates (see [`Self::attach_quads`]). The scene keeps
    /// `filter` alive.
    pub fn attach_filtered_quads<F: HitFilter>(
        &mut self,
        positions: &[[f32; 3]],
        indices: &[[u32; 4]],
        filter: Arc<F>,
    ) -> Result<u32, EmbreeError> {
        self.attach_mesh(
            positions,
            indices,
            sys::RTC_GEOMETRY_TYPE_QUAD,
            sys::RTC_FORMAT_UINT4,
            Some(FilterBinding::new(filter)),
        )
    }

    /// A mesh of `N`-gons (triangles or quads) of Embree geometry type `kind`, its index
    /// buffer items of `format` (`N` × u32), its hits filtered by `filter` if given.
    fn attach_mesh<const N: usize>(
        &mut self,
        positions: &[[f32; 3]],
        indices: &[[u32; N]],
        kind: sys::RTCGeometryType,
        format: sys::RTCFormat,
        filter: Option<FilterBinding>,
    ) -> Result<u32, EmbreeError> {
        if positions.is_empty() || indices.is_empty() {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_INVALID_ARGUMENT,
                message: "a mesh needs at least one vertex and one primitive".into(),
            });
        }
        let vertex_count = positions.len();
        if let Some(bad) = indices
            .iter()
            .flatten()
            .find(|&&i| i as usize >= vertex_count)
        {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_INVALID_ARGUMENT,
                message: format!("vertex index {bad} out of range ({vertex_count} vertices)"),
            });
        }
        let device = self.device.inner.raw;
        // SAFETY: the device is live; a null geometry is reported by device.check().
        let geom = unsafe { sys::rtcNewGeometry(device, kind) };
        self.device.check()?;
        let result = (|| {
            // SAFETY: `geom` is a live geometry. Embree allocates buffers of exactly
            // `count` items of the given stride (plus its own padding); we write no more than
            // `count` items into each, and null pointers are checked before use.
            unsafe {
                sys::rtcSetGeometryBuildQuality(geom, to_quality(self.quality));
                let vb = sys::rtcSetNewGeometryBuffer(
                    geom,
                    sys::RTC_BUFFER_TYPE_VERTEX,
                    0,
                    sys::RTC_FORMAT_FLOAT3,
                    12,
                    vertex_count,
                ) as *mut [f32; 3];
                self.device.check()?;
                if vb.is_null() {
                    return Err(null_buffer("vertex"));
                }
                std::ptr::copy_nonoverlapping(positions.as_ptr(), vb, vertex_count);
                let ib = sys::rtcSetNewGeometryBuffer(
                    geom,
                    sys::RTC_BUFFER_TYPE_INDEX,
                    0,
                    format,
                    4 * N,
                    indices.len(),
                ) as *mut [u32; N];
                self.device.check()?;
                if ib.is_null() {
                    return Err(null_buffer("index"));
                }
                std::ptr::copy_nonoverlapping(indices.as_ptr(), ib, indices.len());
                if let Some(f) = &filter {
                    // The same callback filters closest-hit and any-hit queries. `f.user`
                    // stays valid while the geometry exists: its owner goes into
                    // `self.filters` below and from there into the committed Scene, which
                    // releases the Embree scene (and with it the geometry) before dropping it.
                    sys::rtcSetGeometryUserData(geom, f.user);
                    sys::rtcSetGeometryIntersectFilterFunction(geom, Some(f.callback));
                    sys::rtcSetGeometryOccludedFilterFunction(geom, Some(f.callback));
                    self.device.check()?;
                }
                sys::rtcCommitGeometry(geom);
                let id = sys::rtcAttachGeometry(self.raw, geom);
                self.device.check()?;
                Ok(id)
            }
        })();
        // SAFETY: the scene holds its own reference once attached; ours is released either way.
        unsafe { sys::rtcReleaseGeometry(geom) };
        if let Some(f) = filter {
            // Kept even when attaching failed: the geometry may have been attached anyway.
            self.filters.push(f.owner);
        }
        result
    }

    /// Attaches an instance of the committed scene `child` (built on the same device), placed
    /// by the affine map `transform`: 12 floats in column-major order, the images of the x, y
    /// and z axes and then the translation. Returns its geometry id, which hits on the
    /// child's geometry report as their instance id ([`RawHit::inst_id`]; their geometry and
    /// primitive ids are the child's, their normal in the child's space). The child is kept
    /// alive as long as this scene is.
    pub fn attach_instance(
        &mut self,
        child: &Arc<Scene>,
        transform: &[f32; 12],
    ) -> Result<u32, EmbreeError> {
        if transform.iter().any(|x| !x.is_finite()) {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_INVALID_ARGUMENT,
                message: "an instance's transform is not finite".into(),
            });
        }
        // SAFETY: the device is live; a null geometry is reported by device.check().
        let geom =
            unsafe { sys::rtcNewGeometry(self.device.inner.raw, sys::RTC_GEOMETRY_TYPE_INSTANCE) };
        self.device.check()?;
        // SAFETY: `geom` is a live instance geometry; `child.raw` a committed scene that
        // outlives this one (its Arc goes into `self.children` and then into the committed
        // Scene, released after the Embree scene); Embree copies the 12 floats of the
        // transform, which `transform` holds, during the call.
        let result = unsafe {
            sys::rtcSetGeometryInstancedScene(geom, child.raw);
            sys::rtcSetGeometryTransform(
                geom,
                0,
                sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                transform.as_ptr().cast::<c_void>(),
            );
            sys::rtcCommitGeometry(geom);
            let id = sys::rtcAttachGeometry(self.raw, geom);
            self.device.check().map(|_| id)
        };
        // SAFETY: the scene holds its own reference once attached; ours is released either way.
        unsafe { sys::rtcReleaseGeometry(geom) };
        if !self.children.last().is_some_and(|c| Arc::ptr_eq(c, child)) {
            self.children.push(child.clone());
        }
        result
    }

    /// Builds the BVH. The returned scene is immutable and may be traced from many threads.
    pub fn commit(mut self) -> Result<Scene, EmbreeError> {
        // SAFETY: `raw` is a live scene with committed geometries.
        unsafe { sys::rtcCommitScene(self.raw) };
        self.device.check()?;
        let raw = std::mem::replace(&mut self.raw, std::ptr::null_mut());
        Ok(Scene {
            device: self.device.clone(),
            raw,
            _filters: std::mem::take(&mut self.filters),
            _children: std::mem::take(&mut self.children),
        })
    }
}

fn to_quality(q: BuildQuality) -> sys::RTCBuildQuality {
    match q {
        BuildQuality::Low => sys::RTC_BUILD_QUALITY_LOW,
        BuildQuality::Medium => sys::RTC_BUILD_QUALITY_MEDIUM,
        BuildQuality::High => sys::RTC_BUILD_QUALITY_HIGH,
    }
}

fn null_buffer(what: &str) -> EmbreeError {
    EmbreeError {
        code: sys::RTC_ERROR_OUT_OF_MEMORY,
        message: format!("rtcSetNewGeometryBuffer returned null for the {what} buffer"),
    }
}

/// A committed scene. Queries take `&self` and are safe from any number of threads.
pub struct Scene {
    device: Device,
    raw: sys::RTCScene,
    /// The geometries' hit filters, whose addresses Embree holds as user data: dropped after
    /// `Drop` has released `raw` (fields drop after `drop` runs).
    _filters: Vec<Arc<dyn Any + Send + Sync>>,
    /// The scenes its instances place: released after it, likewise.
    _children: Vec<Arc<Scene>>,
}

// SAFETY: a committed RTCScene is immutable; Embree documents rtcIntersect1/rtcOccluded1 on a
// committed scene as thread-safe, and the scene is only released in Drop (exclusive access).
unsafe impl Send for Scene {}
// SAFETY: as above.
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: `raw` is the scene committed in SceneBuilder::commit, released exactly once.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

// The packet widths are the renderer's ([`crate::ray`]); the wrapper maps them onto
// Embree's 8- and 16-wide queries.
pub use crate::ray::{OCCLUSION_PACKET, PACKET};
const _: () = assert!(PACKET == 8 && OCCLUSION_PACKET == 16);

/// The closest hit of a ray, as Embree reports it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawHit {
    pub t: f32,
    /// The instance's geometry id for a hit inside an instance
    /// ([`SceneBuilder::attach_instance`]), else [`INVALID_GEOMETRY_ID`].
    pub inst_id: u32,
    pub geom_id: u32,
    pub prim_id: u32,
    /// Barycentric coordinates: p = (1 − u − v)·v0 + u·v1 + v·v2.
    pub u: f32,
    pub v: f32,
    /// Unnormalised geometric normal, (v1 − v0) × (v2 − v0) for triangles, in the space of
    /// the geometry (an instanced one's own).
    pub ng: [f32; 3],
}

/// A ray in Embree's own layout, for [`Scene::occluded_count_raw`].
#[derive(Clone, Copy)]
pub struct RawRay(sys::RTCRay);

impl RawRay {
    pub fn new(org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> RawRay {
        RawRay(make_ray(org, dir, tnear, tfar))
    }
}

/// The layout facts the filter callback reads (see [`filter_hits`]).
const _: () = {
    use std::mem::offset_of;
    assert!(offset_of!(sys::RTCRay, id) == 10 * 4);
    assert!(offset_of!(sys::RTCHit, instID) == 7 * 4);
};

fn make_ray(org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> sys::RTCRay {
    sys::RTCRay {
        org_x: org[0],
        org_y: org[1],
        org_z: org[2],
        tnear,
        dir_x: dir[0],
        dir_y: dir[1],
        dir_z: dir[2],
        time: 0.0,
        tfar,
        // Embree 4 enables ray masks by default: a zero mask would miss everything.
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

/// `RTCRay` with its first two 16-byte groups held as SIMD vectors. Embree reads a ray with
/// 16-byte loads; built field by field, a group is written by several smaller stores, and a
/// load that spans several pending stores cannot be forwarded from them and stalls. Built
/// from vectors, each group is one store. The layout equals `RTCRay`'s (checked below).
#[repr(C)]
#[derive(Clone, Copy)]
struct VectorRay {
    org_tnear: glam::Vec4,
    dir_time: glam::Vec4,
    tfar: f32,
    mask: u32,
    id: u32,
    flags: u32,
}

const _: () = {
    use std::mem::{align_of, offset_of, size_of};
    assert!(size_of::<VectorRay>() == size_of::<sys::RTCRay>());
    assert!(align_of::<VectorRay>() == align_of::<sys::RTCRay>());
    assert!(offset_of!(VectorRay, org_tnear) == offset_of!(sys::RTCRay, org_x));
    assert!(offset_of!(sys::RTCRay, tnear) == offset_of!(sys::RTCRay, org_x) + 12);
    assert!(offset_of!(VectorRay, dir_time) == offset_of!(sys::RTCRay, dir_x));
    assert!(offset_of!(sys::RTCRay, time) == offset_of!(sys::RTCRay, dir_x) + 12);
    assert!(offset_of!(VectorRay, tfar) == offset_of!(sys::RTCRay, tfar));
    assert!(offset_of!(VectorRay, mask) == offset_of!(sys::RTCRay, mask));
    assert!(offset_of!(VectorRay, id) == offset_of!(sys::RTCRay, id));
    assert!(offset_of!(VectorRay, flags) == offset_of!(sys::RTCRay, flags));
};

/// `RTCRayHit` with the ray as a [`VectorRay`].
#[repr(C)]
struct VectorRayHit {
    ray: VectorRay,
    hit: sys::RTCHit,
}

const _: () = {
    use std::mem::{align_of, offset_of, size_of};
    assert!(size_of::<VectorRayHit>() == size_of::<sys::RTCRayHit>());
    assert!(align_of::<VectorRayHit>() == align_of::<sys::RTCRayHit>());
    assert!(offset_of!(VectorRayHit, hit) == offset_of!(sys::RTCRayHit, hit));
};

impl VectorRay {
    #[inline(always)]
    fn new(org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32, id: u32) -> VectorRay {
        VectorRay {
            org_tnear: glam::Vec4::new(org[0], org[1], org[2], tnear),
            dir_time: glam::Vec4::new(dir[0], dir[1], dir[2], 0.0),
            tfar,
            // Embree 4 enables ray masks by default: a zero mask would miss everything.
            mask: u32::MAX,
            id,
            flags: 0,
        }
    }
}

/// Embree 4's intersect arguments as `rtcInitIntersectArguments` (an inline function bindgen
/// cannot bind) makes them, with the coherent hint if `coherent`: packet traversal for rays
/// that travel together, instead of the default hybrid traversal. Zeroed bytes follow them:
/// a library built with `RTC_MIN_WIDTH` has one more field than headers without it declare
/// (the CI's Embree 4 pairs 4.2 headers with a 4.4 library), and reads it as 0 there instead
/// of past the struct.
#[cfg(embree4)]
#[repr(C)]
struct IntersectArguments {
    args: sys::RTCIntersectArguments,
    _tail: [u64; 4],
}

#[cfg(embree4)]
impl IntersectArguments {
    /// The arguments for Embree, as a pointer to the whole struct (padding included).
    #[inline]
    fn as_mut_ptr(&mut self) -> *mut sys::RTCIntersectArguments {
        (self as *mut IntersectArguments).cast()
    }
}

#[cfg(embree4)]
#[inline]
fn intersect_arguments(coherent: bool) -> IntersectArguments {
    // SAFETY: all-zero bytes are a valid value of this C struct (null context, no filter or
    // intersect callbacks) and of the padding.
    let mut a: IntersectArguments = unsafe { std::mem::zeroed() };
    a.args.flags = if coherent {
        sys::RTC_RAY_QUERY_FLAG_COHERENT
    } else {
        sys::RTC_RAY_QUERY_FLAG_INCOHERENT
    };
    a.args.feature_mask = sys::RTC_FEATURE_FLAG_ALL;
    a
}

#[cfg(embree3)]
#[inline]
fn intersect_context() -> sys::RTCIntersectContext {
    // rtcInitIntersectContext is an inline function bindgen cannot bind; this is its body.
    let mut ctx = sys::RTCIntersectContext {
        flags: sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        ..Default::default()
    };
    ctx.filter = None;
    ctx.instID.fill(INVALID_GEOMETRY_ID);
    ctx
}

/// [`intersect_context`] with the coherent hint if `coherent`: packet traversal for rays that
/// travel together, instead of the default hybrid traversal (Embree 3's counterpart of
/// `intersect_arguments`).
#[cfg(embree3)]
#[inline]
fn hinted_context(coherent: bool) -> sys::RTCIntersectContext {
    let mut ctx = intersect_context();
    if coherent {
        ctx.flags = sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    }
    ctx
}

/// The valid mask of a packet of up to 16 rays, aligned as Embree requires (to the packet's
/// size in bytes: 32 for 8 rays, 64 for 16).
#[repr(C, align(64))]
struct Valid<const N: usize>([i32; N]);

/// Embree's structure-of-arrays ray packets (`RTCRay8`, `RTCRay16`), written lane by lane.
trait RayLanes<const N: usize>: Sized {
    /// The packet with every field zero.
    fn zeroed() -> Self;
    fn set(&mut self, i: usize, lane: Lane);
    /// Embree's any-hit query of the lanes `valid` marks, in `scene` (committed).
    fn occlude(&mut self, valid: &Valid<N>, scene: sys::RTCScene);
    /// True when an occlusion query found an occluder for lane i (Embree sets tfar to −∞).
    fn occluded(&self, i: usize) -> bool;
}

macro_rules! ray_lanes {
    ($packet:ty, $n:literal, $occluded:ident) => {
        impl RayLanes<$n> for $packet {
            #[inline(always)]
            fn zeroed() -> Self {
                // SAFETY: all-zero bytes are a valid value of this plain struct of floats and
                // integers.
                unsafe { std::mem::zeroed() }
            }
            #[inline(always)]
            fn set(&mut self, i: usize, (org, dir, tnear, tfar, id): Lane) {
                self.id[i] = id;
                self.org_x[i] = org[0];
                self.org_y[i] = org[1];
                self.org_z[i] = org[2];
                self.tnear[i] = tnear;
                self.dir_x[i] = dir[0];
                self.dir_y[i] = dir[1];
                self.dir_z[i] = dir[2];
                self.tfar[i] = tfar;
                // Embree 4 enables ray masks by default: a zero mask would miss everything.
                self.mask[i] = u32::MAX;
            }
            #[inline(always)]
            fn occlude(&mut self, valid: &Valid<$n>, scene: sys::RTCScene) {
                #[cfg(embree3)]
                {
                    let mut ctx = intersect_context();
                    // SAFETY: the caller's scene is committed; `valid` is aligned as the
                    // packet API requires; `self` and `ctx` are valid and Embree uses them
                    // only during the call.
                    unsafe { sys::$occluded(valid.0.as_ptr(), scene, &mut ctx, self) };
                }
                #[cfg(embree4)]
                {
                    // SAFETY: as above; null arguments select Embree 4's defaults.
                    unsafe { sys::$occluded(valid.0.as_ptr(), scene, self, std::ptr::null_mut()) };
                }
            }
            #[inline(always)]
            fn occluded(&self, i: usize) -> bool {
                self.tfar[i] == f32::NEG_INFINITY
            }
        }
    };
}
ray_lanes!(sys::RTCRay8, 8, rtcOccluded8);
ray_lanes!(sys::RTCRay16, 16, rtcOccluded16);

/// One ray of a packet: origin, direction, tnear, tfar and id ([`Scene::intersect_id`]).
pub type Lane = ([f32; 3], [f32; 3], f32, f32, u32);

/// Writes `ray(&rays[i])` into lane i of `packet` and returns the mask with those lanes
/// valid.
#[inline(always)]
fn pack<const N: usize, R>(
    rays: &[R],
    ray: impl Fn(&R) -> Lane,
    packet: &mut impl RayLanes<N>,
) -> Valid<N> {
    assert!(rays.len() <= N, "more rays than a packet holds");
    let mut valid = Valid([0; N]);
    for (i, r) in rays.iter().enumerate() {
        packet.set(i, ray(r));
        valid.0[i] = -1;
    }
    valid
}

/// Generates a measuring function that traces rays as packets of `$n` with Embree's packet
/// API (`$func`), for comparison with one-ray-at-a-time tracing.
macro_rules! packet_count_raw {
    ($name:ident, $n:literal, $rayhit:ident, $func:ident) => {
        /// Closest hits of `rays` traced in packets (Embree's packet API, with the coherent
        /// hint if `coherent`, which selects packet traversal, else with the default hint,
        /// which lets Embree switch to one ray at a time as the rays part); returns how many
        /// hit. Includes the cost of packing the rays into Embree's structure-of-arrays
        /// layout, which a renderer would pay too. Lanes past the end of `rays` are masked
        /// off.
        pub fn $name(&self, rays: &[RawRay], coherent: bool) -> usize {
            /// The valid mask must be aligned to the packet's size in bytes.
            #[repr(C, align(64))]
            struct Valid([i32; $n]);
            #[cfg(embree3)]
            let mut ctx = hinted_context(coherent);
            #[cfg(embree4)]
            let mut args = intersect_arguments(coherent);
            let mut count = 0;
            for chunk in rays.chunks($n) {
                // SAFETY: all-zero bytes are a valid value of this plain struct of floats and
                // integers.
                let mut rh: sys::$rayhit = unsafe { std::mem::zeroed() };
                let mut valid = Valid([0; $n]);
                for (i, r) in chunk.iter().enumerate() {
                    let r = &r.0;
                    rh.ray.org_x[i] = r.org_x;
                    rh.ray.org_y[i] = r.org_y;
                    rh.ray.org_z[i] = r.org_z;
                    rh.ray.tnear[i] = r.tnear;
                    rh.ray.dir_x[i] = r.dir_x;
                    rh.ray.dir_y[i] = r.dir_y;
                    rh.ray.dir_z[i] = r.dir_z;
                    rh.ray.tfar[i] = r.tfar;
                    rh.ray.mask[i] = r.mask;
                    rh.hit.geomID[i] = INVALID_GEOMETRY_ID;
                    valid.0[i] = -1;
                }
                #[cfg(embree3)]
                // SAFETY: the scene is committed; `valid` is aligned as the packet API
                // requires and `rh`, `ctx` are valid locals Embree uses only during the call.
                unsafe {
                    sys::$func(valid.0.as_ptr(), self.raw, &mut ctx, &mut rh)
                };
                #[cfg(embree4)]
                // SAFETY: as above, with `args` a valid local too.
                unsafe {
                    sys::$func(valid.0.as_ptr(), self.raw, &mut rh, args.as_mut_ptr())
                };
                count += rh.hit.geomID[..chunk.len()]
                    .iter()
                    .filter(|&&g| g != INVALID_GEOMETRY_ID)
                    .count();
            }
            count
        }
    };
}

impl Scene {
    /// The closest hit along `org + t·dir` for t in `[tnear, tfar]`, if any.
    #[inline]
    pub fn intersect(&self, org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> Option<RawHit> {
        self.intersect_id(org, dir, tnear, tfar, 0)
    }

    /// [`Scene::intersect`] of a ray with id `id`, which hit filters receive
    /// ([`HitFilter::accept`]) in and out of instances alike.
    #[inline]
    pub fn intersect_id(
        &self,
        org: [f32; 3],
        dir: [f32; 3],
        tnear: f32,
        tfar: f32,
        id: u32,
    ) -> Option<RawHit> {
        let mut rayhit = VectorRayHit {
            ray: VectorRay::new(org, dir, tnear, tfar, id),
            hit: sys::RTCHit {
                geomID: INVALID_GEOMETRY_ID,
                primID: INVALID_GEOMETRY_ID,
                instID: [INVALID_GEOMETRY_ID; sys::RTC_MAX_INSTANCE_LEVEL_COUNT as usize],
                ..Default::default()
            },
        };
        let ptr = (&mut rayhit as *mut VectorRayHit).cast::<sys::RTCRayHit>();
        #[cfg(embree3)]
        {
            let mut ctx = intersect_context();
            // SAFETY: the scene is committed; `ptr` points to a live, aligned local whose
            // layout equals RTCRayHit (checked at compile time); `ctx` is a valid local. Embree
            // reads and writes them only during the call.
            unsafe { sys::rtcIntersect1(self.raw, &mut ctx, ptr) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as above; null arguments select Embree 4's defaults.
            unsafe { sys::rtcIntersect1(self.raw, ptr, std::ptr::null_mut()) };
        }
        if rayhit.hit.geomID == INVALID_GEOMETRY_ID {
            return None;
        }
        Some(RawHit {
            t: rayhit.ray.tfar,
            inst_id: rayhit.hit.instID[0],
            geom_id: rayhit.hit.geomID,
            prim_id: rayhit.hit.primID,
            u: rayhit.hit.u,
            v: rayhit.hit.v,
            ng: [rayhit.hit.Ng_x, rayhit.hit.Ng_y, rayhit.hit.Ng_z],
        })
    }

    /// The closest hits of up to [`PACKET`] coherent rays (camera rays of neighbouring pixels)
    /// in one call of Embree's 8-wide packet API, with the coherent hint.
    /// `ray(&rays[i])` gives ray i as a [`Lane`], and `hit(i, …)` receives its
    /// answer, for every i < `rays.len()`; the other lanes are masked off. (Closures, so that
    /// callers pack from and unpack into their own types without intermediate copies.) The
    /// answers equal those of [`Scene::intersect`] ray by ray (tested in tests/embree.rs),
    /// except where a ray meets two triangles at the same distance (an edge they share): the
    /// traversals visit them in different orders and may report either.
    #[inline]
    pub fn intersect_packet<R>(
        &self,
        rays: &[R],
        ray: impl Fn(&R) -> Lane,
        mut hit: impl FnMut(usize, Option<RawHit>),
    ) {
        // SAFETY: all-zero bytes are a valid value of this plain struct of floats and
        // integers.
        let mut rh: sys::RTCRayHit8 = unsafe { std::mem::zeroed() };
        let valid: Valid<PACKET> = pack(rays, ray, &mut rh.ray);
        rh.hit.geomID = [INVALID_GEOMETRY_ID; PACKET];
        rh.hit.instID[0] = [INVALID_GEOMETRY_ID; PACKET];
        #[cfg(embree3)]
        {
            let mut ctx = hinted_context(true);
            // SAFETY: the scene is committed; `valid` is aligned as the packet API requires;
            // `rh` and `ctx` are valid locals Embree uses only during the call.
            unsafe { sys::rtcIntersect8(valid.0.as_ptr(), self.raw, &mut ctx, &mut rh) };
        }
        #[cfg(embree4)]
        {
            let mut args = intersect_arguments(true);
            // SAFETY: as above, with `args` a valid local too.
            unsafe { sys::rtcIntersect8(valid.0.as_ptr(), self.raw, &mut rh, args.as_mut_ptr()) };
        }
        for i in 0..rays.len() {
            hit(
                i,
                (rh.hit.geomID[i] != INVALID_GEOMETRY_ID).then(|| RawHit {
                    t: rh.ray.tfar[i],
                    inst_id: rh.hit.instID[0][i],
                    geom_id: rh.hit.geomID[i],
                    prim_id: rh.hit.primID[i],
                    u: rh.hit.u[i],
                    v: rh.hit.v[i],
                    ng: [rh.hit.Ng_x[i], rh.hit.Ng_y[i], rh.hit.Ng_z[i]],
                }),
            );
        }
    }

    /// Any-hit queries of up to [`OCCLUSION_PACKET`] rays in one call of Embree's API (a
    /// single-ray query for one ray, 8-wide for up to 8, else 16-wide), for rays that share
    /// much of their path (the AO rays of one surface point): `occluded(i)` receives ray i's
    /// answer. As [`Scene::intersect_packet`] otherwise.
    #[inline]
    pub fn occluded_packet<R>(
        &self,
        rays: &[R],
        ray: impl Fn(&R) -> Lane,
        mut occluded: impl FnMut(usize, bool),
    ) {
        match rays.len() {
            0 => {}
            1 => {
                let (org, dir, tnear, tfar, id) = ray(&rays[0]);
                occluded(0, self.occluded_id(org, dir, tnear, tfar, id));
            }
            2..=PACKET => self.occluded_lanes::<PACKET, sys::RTCRay8, R>(rays, ray, occluded),
            _ => self.occluded_lanes::<OCCLUSION_PACKET, sys::RTCRay16, R>(rays, ray, occluded),
        }
    }

    /// [`Scene::occluded_packet`] with packets of `N` rays.
    #[inline(always)]
    fn occluded_lanes<const N: usize, P: RayLanes<N>, R>(
        &self,
        rays: &[R],
        ray: impl Fn(&R) -> Lane,
        mut occluded: impl FnMut(usize, bool),
    ) {
        let mut packet = P::zeroed();
        let valid = pack(rays, ray, &mut packet);
        packet.occlude(&valid, self.raw);
        (0..rays.len()).for_each(|i| occluded(i, packet.occluded(i)));
    }

    /// True when anything lies along `org + t·dir` for t in `[tnear, tfar]`.
    #[inline]
    pub fn occluded(&self, org: [f32; 3], dir: [f32; 3], tnear: f32, tfar: f32) -> bool {
        self.occluded_id(org, dir, tnear, tfar, 0)
    }

    /// [`Scene::occluded`] of a ray with id `id` (see [`Scene::intersect_id`]).
    #[inline]
    pub fn occluded_id(
        &self,
        org: [f32; 3],
        dir: [f32; 3],
        tnear: f32,
        tfar: f32,
        id: u32,
    ) -> bool {
        let mut ray = VectorRay::new(org, dir, tnear, tfar, id);
        let ptr = (&mut ray as *mut VectorRay).cast::<sys::RTCRay>();
        #[cfg(embree3)]
        {
            let mut ctx = intersect_context();
            // SAFETY: the scene is committed; `ptr` points to a live, aligned local whose
            // layout equals RTCRay (checked at compile time); `ctx` is a valid local.
            unsafe { sys::rtcOccluded1(self.raw, &mut ctx, ptr) };
        }
        #[cfg(embree4)]
        {
            // SAFETY: as above; null arguments select Embree 4's defaults.
            unsafe { sys::rtcOccluded1(self.raw, ptr, std::ptr::null_mut()) };
        }
        // Embree sets tfar to -inf when an occluder is found.
        ray.tfar == f32::NEG_INFINITY
    }

    /// A measuring baseline for the cost of strata's own layers: traces `rays` with
    /// `rtcOccluded1` in a tight loop (one context for the batch, rays already in Embree's
    /// layout) and returns how many are occluded. Benchmarks compare it with the same rays
    /// through [`crate::accel::Accel::occluded`].
    pub fn occluded_count_raw(&self, rays: &[RawRay]) -> usize {
        let mut count = 0;
        #[cfg(embree3)]
        let mut ctx = intersect_context();
        for r in rays {
            let mut ray = r.0;
            #[cfg(embree3)]
            // SAFETY: the scene is committed; `ctx` and `ray` are valid, aligned locals.
            unsafe {
                sys::rtcOccluded1(self.raw, &mut ctx, &mut ray)
            };
            #[cfg(embree4)]
            // SAFETY: the scene is committed; `ray` is a valid, aligned local; null arguments
            // select Embree 4's defaults.
            unsafe {
                sys::rtcOccluded1(self.raw, &mut ray, std::ptr::null_mut())
            };
            count += (ray.tfar == f32::NEG_INFINITY) as usize;
        }
        count
    }

    /// The closest-hit counterpart of [`Scene::occluded_count_raw`]: traces `rays` with
    /// `rtcIntersect1` in a tight loop and returns how many hit something.
    pub fn intersect_count_raw(&self, rays: &[RawRay]) -> usize {
        let mut count = 0;
        #[cfg(embree3)]
        let mut ctx = intersect_context();
        for r in rays {
            let mut rayhit = sys::RTCRayHit {
                ray: r.0,
                hit: sys::RTCHit {
                    geomID: INVALID_GEOMETRY_ID,
                    primID: INVALID_GEOMETRY_ID,
                    ..Default::default()
                },
            };
            #[cfg(embree3)]
            // SAFETY: the scene is committed; `ctx` and `rayhit` are valid, aligned locals.
            unsafe {
                sys::rtcIntersect1(self.raw, &mut ctx, &mut rayhit)
            };
            #[cfg(embree4)]
            // SAFETY: the scene is committed; `rayhit` is a valid, aligned local; null
            // arguments select Embree 4's defaults.
            unsafe {
                sys::rtcIntersect1(self.raw, &mut rayhit, std::ptr::null_mut())
            };
            count += (rayhit.hit.geomID != INVALID_GEOMETRY_ID) as usize;
        }
        count
    }

    packet_count_raw!(intersect4_count_raw, 4, RTCRayHit4, rtcIntersect4);
    packet_count_raw!(intersect8_count_raw, 8, RTCRayHit8, rtcIntersect8);
    packet_count_raw!(intersect16_count_raw, 16, RTCRayHit16, rtcIntersect16);

    /// The Embree device this scene belongs to.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Axis-aligned bounds of the committed scene: (lower, upper).
    pub fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let mut b = sys::RTCBounds::default();
        // SAFETY: the scene is committed; `b` is a valid, aligned local.
        unsafe { sys::rtcGetSceneBounds(self.raw, &mut b) };
        (
            [b.lower_x, b.lower_y, b.lower_z],
            [b.upper_x, b.upper_y, b.upper_z],
        )
    }
}
