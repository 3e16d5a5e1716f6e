// LAS / LAZ internals shared by the reader and the writer (las.cpp, las_write.cpp): the layout
// of the point formats, the extra-bytes descriptors, and LasSource, which a read cloud carries
// so that writing LAS/LAZ again passes every attribute through bit-exact. Not installed.
#pragma once

#include "io/detail.hpp"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace nhnet {

/// One variable length record (VLR, 54-byte header) or extended VLR (EVLR, 60-byte header).
struct LasVlr {
  std::string head;     ///< the record header as read (54 or 60 bytes)
  std::string payload;  ///< the data after it
};

/// An extra-bytes field (LAS 1.4 R15 Table 24), as found in the extra-bytes VLR.
struct LasExtraField {
  std::string descriptor;  ///< the 192-byte descriptor, as read or made
  std::string name;        ///< its name (from the descriptor)
  uint8_t data_type = 0;   ///< 0 undocumented bytes, 1..10 scalars, 11..30 deprecated arrays
  size_t offset = 0;       ///< byte offset inside the point record
  size_t size = 0;         ///< bytes it takes in the record
};

struct LasSource {
  std::string header;                   ///< the public header block as read
  std::vector<LasVlr> vlrs;             ///< VLRs as read, without the laszip and extra-bytes ones
  std::vector<LasExtraField> extras;    ///< extra-bytes fields, in record order
  std::vector<LasVlr> evlrs;            ///< EVLRs as read (LAS 1.3 waveform record, 1.4 EVLRs)
  uint64_t evlr_start = 0;              ///< where the EVLRs started in the input (0: none)
  uint8_t format = 0;                   ///< point data format, 0..10
  size_t record_length = 0;             ///< bytes per point record
  std::string records;                  ///< N * record_length bytes, uncompressed
  std::array<double, 3> scale{};        ///< X Y Z scale factors
  std::array<double, 3> offset{};       ///< X Y Z offsets
  std::vector<std::string> read_names;  ///< names of the extras the reader made from the records
};

namespace io_detail {

/// Bytes of the standard fields of point format 0..10 (LAS 1.4 R15 Tables 7-17).
size_t las_standard_size(uint8_t format);

/// Scalar type of extra-bytes data type 1..10; false for the others (undocumented, 64-bit
/// integers kept as Float64 are reported as Float64 with `exact` false).
bool las_extra_scalar(uint8_t data_type, ScalarType& type);

/// Byte size of extra-bytes data type 1..10 (0 for others).
size_t las_extra_type_size(uint8_t data_type);

/// Little-endian field access.
template <typename T>
T get_le(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}
template <typename T>
void put_le(char* p, T v) {
  std::memcpy(p, &v, sizeof(T));
}

/// A 192-byte extra-bytes descriptor for `name` of `data_type` (no scale, offset, no-data).
std::string las_extra_descriptor(const std::string& name, uint8_t data_type,
                                 uint8_t undocumented_size = 0);

/// Number, kind and offset of the standard attributes exposed as extras for `format`.
struct LasAttribute {
  const char* name;
  ScalarType type;
  size_t offset;  ///< byte offset in the record
  int bits_shift = 0;
  int bits_mask = 0;  ///< 0: the whole scalar; else (byte >> shift) & mask
};
std::vector<LasAttribute> las_attributes(uint8_t format);

}  // namespace io_detail
}  // namespace nhnet
