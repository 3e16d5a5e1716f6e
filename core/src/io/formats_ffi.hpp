// The C ABI of core/rust (the laz and e57 crates), used by las.cpp and e57.cpp. Not installed.
// Every function returns 0 on success, 1 on failure with a one-line message in `err`.
#pragma once

#include <cstddef>
#include <cstdint>

extern "C" {

/// A byte buffer owned by the Rust side; release with nhnet_buf_free.
struct NhBuf {
  uint8_t* ptr;
  size_t len;
  size_t cap;
};
void nhnet_buf_free(NhBuf* buf);

int nhnet_laz_decompress(const uint8_t* file, size_t file_len, const uint8_t* vlr, size_t vlr_len,
                         uint64_t point_offset, uint8_t* out, size_t out_len, char* err,
                         size_t err_cap);
int nhnet_laz_vlr(uint8_t format, uint16_t extra_bytes, NhBuf* out, char* err, size_t err_cap);
int nhnet_laz_compress(const uint8_t* prefix, size_t prefix_len, const uint8_t* vlr, size_t vlr_len,
                       const uint8_t* points, size_t points_len, NhBuf* out, char* err,
                       size_t err_cap);

struct NhE57File;
/// What a scan read and a scan to write have in common: name, pose (scan frame to file frame),
/// coordinates and normals in the scan's own frame; arrays null when absent.
struct NhE57ScanHead {
  const uint8_t* name;
  size_t name_len;
  int32_t has_pose;
  double quat[4];  // w x y z
  double trans[3];
  size_t n;  // points
  const double* xyz;
  const float* intensity;
  const float* normals;
};
/// One scan as read.
struct NhE57ScanView {
  NhE57ScanHead head;
  const float* rgb;
  double color_max;
  uint64_t dropped;  // points whose invalid-state flag was set
};
int nhnet_e57_read(const uint8_t* data, size_t len, NhE57File** out, char* err, size_t err_cap);
size_t nhnet_e57_scan_count(const NhE57File* file);
void nhnet_e57_scan(const NhE57File* file, size_t index, NhE57ScanView* view);
void nhnet_e57_free(NhE57File* file);

/// One scan to write.
struct NhE57ScanIn {
  NhE57ScanHead head;
  const uint16_t* rgb;
  int64_t rgb_max;
  const float* confidence;  ///< Cloud::confidence, or null
};
int nhnet_e57_write(const NhE57ScanIn* scans, size_t count, NhBuf* out, char* err, size_t err_cap);

}  // extern "C"

// The structs above are declared again, #[repr(C)], in core/rust/src/lib.rs: two languages, so
// two declarations. Their layout is pinned here; the Rust test `c_layout_matches_formats_ffi_hpp`
// (ctest rust.ffi_layout) reads these lines and checks the same sizes and offsets on its side, so
// a field changed on one side only fails a build or that test.
static_assert(sizeof(NhBuf) == 24 && offsetof(NhBuf, len) == 8 && offsetof(NhBuf, cap) == 16);
static_assert(sizeof(NhE57ScanHead) == 112 && offsetof(NhE57ScanHead, name_len) == 8 &&
              offsetof(NhE57ScanHead, has_pose) == 16 && offsetof(NhE57ScanHead, quat) == 24 &&
              offsetof(NhE57ScanHead, trans) == 56 && offsetof(NhE57ScanHead, n) == 80 &&
              offsetof(NhE57ScanHead, xyz) == 88 && offsetof(NhE57ScanHead, intensity) == 96 &&
              offsetof(NhE57ScanHead, normals) == 104);
static_assert(sizeof(NhE57ScanView) == 136 && offsetof(NhE57ScanView, rgb) == 112 &&
              offsetof(NhE57ScanView, color_max) == 120 && offsetof(NhE57ScanView, dropped) == 128);
static_assert(sizeof(NhE57ScanIn) == 136 && offsetof(NhE57ScanIn, rgb) == 112 &&
              offsetof(NhE57ScanIn, rgb_max) == 120 && offsetof(NhE57ScanIn, confidence) == 128);

namespace nhnet::io_detail {

/// Owns an NhBuf.
struct RustBuf {
  NhBuf buf{nullptr, 0, 0};
  RustBuf() = default;
  RustBuf(const RustBuf&) = delete;
  RustBuf& operator=(const RustBuf&) = delete;
  ~RustBuf() { nhnet_buf_free(&buf); }
};

}  // namespace nhnet::io_detail
