//! The calls into Google's Draco decoder, through the small C interface of `shim.cc` (built by
//! `build.rs` against the system's libdraco): a decoded mesh, released on drop, its faces, and
//! the raw bytes of an attribute in point order. The only `unsafe` code of the Draco support.

use std::ffi::{c_char, CStr};

/// The shim's opaque mesh.
#[repr(C)]
struct RawMesh {
    _private: [u8; 0],
}

extern "C" {
    fn strata_draco_decode(
        data: *const u8,
        len: usize,
        message: *mut c_char,
        message_len: usize,
    ) -> *mut RawMesh;
    fn strata_draco_free(mesh: *mut RawMesh);
    fn strata_draco_num_points(mesh: *const RawMesh) -> u32;
    fn strata_draco_num_faces(mesh: *const RawMesh) -> u32;
    fn strata_draco_faces(mesh: *const RawMesh, out: *mut u32, out_len: usize) -> i32;
    fn strata_draco_attribute(
        mesh: *const RawMesh,
        id: u32,
        components: *mut i32,
        data_type: *mut i32,
        normalized: *mut i32,
    ) -> i32;
    fn strata_draco_attribute_values(
        mesh: *const RawMesh,
        id: u32,
        out: *mut u8,
        out_len: usize,
    ) -> i32;
}

/// Draco's attribute data types (`draco::DataType`), with their sizes in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
    Bool,
}

impl DataType {
    fn from_draco(code: i32) -> Option<DataType> {
        use DataType::*;
        Some(match code {
            1 => I8,
            2 => U8,
            3 => I16,
            4 => U16,
            5 => I32,
            6 => U32,
            7 => I64,
            8 => U64,
            9 => F32,
            10 => F64,
            11 => Bool,
            _ => return None,
        })
    }

    pub fn size(self) -> usize {
        use DataType::*;
        match self {
            I8 | U8 | Bool => 1,
            I16 | U16 => 2,
            I32 | U32 | F32 => 4,
            I64 | U64 | F64 => 8,
        }
    }
}

/// What an attribute holds per point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Attribute {
    pub components: usize,
    pub data_type: DataType,
    pub normalized: bool,
}

/// A decoded Draco triangle mesh.
pub struct Mesh(*mut RawMesh);

impl Drop for Mesh {
    fn drop(&mut self) {
        // SAFETY: a mesh the shim returned, freed once (Mesh is neither Clone nor Copy).
        unsafe { strata_draco_free(self.0) }
    }
}

impl Mesh {
    /// Decodes `bytes`, a Draco stream, or says why Draco could not.
    pub fn decode(bytes: &[u8]) -> Result<Mesh, String> {
        let mut message = [0 as c_char; 256];
        // SAFETY: `bytes` is valid for `bytes.len()` reads for the call; the shim writes at
        // most `message.len()` bytes, NUL-terminated, into `message`.
        let raw = unsafe {
            strata_draco_decode(
                bytes.as_ptr(),
                bytes.len(),
                message.as_mut_ptr(),
                message.len(),
            )
        };
        if raw.is_null() {
            // SAFETY: the shim NUL-terminated the message inside the array (which it left
            // zeroed, hence terminated, if it wrote nothing).
            let text = unsafe { CStr::from_ptr(message.as_ptr()) }.to_string_lossy();
            return Err(match text.is_empty() {
                true => "Draco could not decode it".into(),
                false => text.into_owned(),
            });
        }
        Ok(Mesh(raw))
    }

    pub fn num_points(&self) -> usize {
        // SAFETY: a live mesh.
        unsafe { strata_draco_num_points(self.0) as usize }
    }

    pub fn num_faces(&self) -> usize {
        // SAFETY: a live mesh.
        unsafe { strata_draco_num_faces(self.0) as usize }
    }

    /// The faces' corners, three point indices per face.
    pub fn faces(&self) -> Vec<u32> {
        let mut out = vec![0u32; 3 * self.num_faces()];
        // SAFETY: a live mesh; `out` has room for exactly `out.len()` indices, the length
        // the shim checks against 3 × its face count.
        let status = unsafe { strata_draco_faces(self.0, out.as_mut_ptr(), out.len()) };
        assert_eq!(
            status, 0,
            "the buffer is sized from the mesh's own face count"
        );
        out
    }

    /// The attribute whose unique id is `id`, or None when the mesh has none.
    pub fn attribute(&self, id: u32) -> Option<Attribute> {
        let (mut components, mut data_type, mut normalized) = (0, 0, 0);
        // SAFETY: a live mesh; the three outputs are valid i32s.
        let status = unsafe {
            strata_draco_attribute(self.0, id, &mut components, &mut data_type, &mut normalized)
        };
        (status == 0).then_some(())?;
        Some(Attribute {
            components: usize::try_from(components).ok()?,
            data_type: DataType::from_draco(data_type)?,
            normalized: normalized != 0,
        })
    }

    /// The raw little-endian values of attribute `id` (`attribute`), point after point.
    pub fn attribute_values(&self, id: u32, attribute: &Attribute) -> Result<Vec<u8>, String> {
        let len = self.num_points() * attribute.components * attribute.data_type.size();
        let mut out = vec![0u8; len];
        // SAFETY: a live mesh; `out` has room for `len` bytes, which the shim checks against
        // the attribute's own size before writing.
        let status =
            unsafe { strata_draco_attribute_values(self.0, id, out.as_mut_ptr(), out.len()) };
        match status {
            0 => Ok(out),
            -1 => Err(format!("the Draco mesh has no attribute {id}")),
            _ => Err(format!(
                "the Draco mesh's attribute {id} does not hold a value for each of its {} points",
                self.num_points()
            )),
        }
    }
}
