// A C interface to Google's Draco decoder (the reference implementation of the Draco
// bitstream that KHR_draco_mesh_compression names), for strata's Rust FFI module
// (src/scene/draco/ffi.rs). It decodes a triangle mesh and copies out its faces and the raw
// bytes of an attribute, point by point; every conversion to glTF's types is done in Rust.
// No C++ exception crosses this interface: each entry point catches them all.

#include <cstdint>
#include <cstring>
#include <exception>
#include <memory>
#include <string>

#include <draco/compression/decode.h>
#include <draco/core/draco_types.h>
#include <draco/mesh/mesh.h>

struct StrataDracoMesh {
  std::unique_ptr<draco::Mesh> mesh;
};

namespace {

void write_message(char *out, size_t out_len, const std::string &message) {
  if (out == nullptr || out_len == 0) return;
  size_t n = message.size() < out_len - 1 ? message.size() : out_len - 1;
  std::memcpy(out, message.data(), n);
  out[n] = '\0';
}

}  // namespace

extern "C" {

// Decodes `len` bytes at `data` as a Draco triangle mesh. Returns the mesh, or null with a
// NUL-terminated message in `message` (at most `message_len` bytes).
StrataDracoMesh *strata_draco_decode(const uint8_t *data, size_t len, char *message,
                                     size_t message_len) {
  try {
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char *>(data), len);
    auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
    if (!type.ok()) {
      write_message(message, message_len, type.status().error_msg_string());
      return nullptr;
    }
    if (type.value() != draco::TRIANGULAR_MESH) {
      write_message(message, message_len,
                    "the Draco stream holds a point cloud, not a triangle mesh");
      return nullptr;
    }
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
    if (!decoded.ok()) {
      write_message(message, message_len, decoded.status().error_msg_string());
      return nullptr;
    }
    auto *out = new StrataDracoMesh;
    out->mesh = std::move(decoded).value();
    if (!out->mesh) {
      delete out;
      write_message(message, message_len, "the decoder returned no mesh");
      return nullptr;
    }
    return out;
  } catch (const std::exception &e) {
    write_message(message, message_len, std::string("the decoder failed: ") + e.what());
    return nullptr;
  } catch (...) {
    write_message(message, message_len, "the decoder failed");
    return nullptr;
  }
}

void strata_draco_free(StrataDracoMesh *mesh) { delete mesh; }

uint32_t strata_draco_num_points(const StrataDracoMesh *mesh) {
  return mesh->mesh->num_points();
}

uint32_t strata_draco_num_faces(const StrataDracoMesh *mesh) {
  return mesh->mesh->num_faces();
}

// Writes the faces' corners (3 × num_faces point indices) to `out`, which holds `out_len`.
// Returns 0, or -1 when `out_len` is not exactly 3 × num_faces.
int32_t strata_draco_faces(const StrataDracoMesh *mesh, uint32_t *out, size_t out_len) {
  const draco::Mesh &m = *mesh->mesh;
  if (out_len != static_cast<size_t>(m.num_faces()) * 3) return -1;
  for (uint32_t f = 0; f < m.num_faces(); ++f) {
    const draco::Mesh::Face &face = m.face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) out[3 * f + k] = face[k].value();
  }
  return 0;
}

// Describes the attribute whose unique id is `id`: its component count, data type (Draco's
// DataType numbering) and normalized flag. Returns 0, or -1 when the mesh has no such
// attribute.
int32_t strata_draco_attribute(const StrataDracoMesh *mesh, uint32_t id, int32_t *components,
                               int32_t *data_type, int32_t *normalized) {
  const draco::PointAttribute *att = mesh->mesh->GetAttributeByUniqueId(id);
  if (att == nullptr) return -1;
  *components = att->num_components();
  *data_type = att->data_type();
  *normalized = att->normalized() ? 1 : 0;
  return 0;
}

// Copies the attribute `id`'s value of every point, in point order, as raw bytes
// (num_points × components × the data type's size, which `out_len` must equal). Returns 0,
// -1 for no such attribute, -2 for a wrong `out_len`, -3 when the decoded attribute's
// storage does not hold a point's value.
int32_t strata_draco_attribute_values(const StrataDracoMesh *mesh, uint32_t id, uint8_t *out,
                                      size_t out_len) {
  const draco::Mesh &m = *mesh->mesh;
  const draco::PointAttribute *att = m.GetAttributeByUniqueId(id);
  if (att == nullptr) return -1;
  const int32_t type_size = draco::DataTypeLength(att->data_type());
  if (type_size <= 0) return -3;
  const size_t element = static_cast<size_t>(type_size) * att->num_components();
  if (out_len != element * m.num_points()) return -2;
  const draco::DataBuffer *storage = att->buffer();
  if (storage == nullptr || att->byte_stride() < static_cast<int64_t>(element) ||
      att->byte_offset() < 0)
    return -3;
  const uint64_t stored = storage->data_size();
  for (uint32_t p = 0; p < m.num_points(); ++p) {
    const draco::PointIndex point(p);
    if (!att->is_mapping_identity() && p >= att->indices_map_size()) return -3;
    const draco::AttributeValueIndex value = att->mapped_index(point);
    if (value.value() >= att->size()) return -3;
    const uint64_t at = static_cast<uint64_t>(att->byte_offset()) +
                        static_cast<uint64_t>(att->byte_stride()) * value.value();
    if (at + element > stored) return -3;
    std::memcpy(out + element * p, storage->data() + at, element);
  }
  return 0;
}

}  // extern "C"
