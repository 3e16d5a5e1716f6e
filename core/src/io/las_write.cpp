// LAS / LAZ writer.
//
// A cloud read from LAS/LAZ (Cloud::las_source) with its point count unchanged is written back
// from its raw records: header, VLRs, EVLRs and every attribute bit-exact, X/Y/Z kept as read
// unless the point moved (then re-quantized with the input's scale and offset). Any other cloud
// is written as LAS 1.4 point format 6 (7 with red/green/blue extras, 8 with nir too), its
// offset the centre of the bounding box and its scale the power of ten that keeps the
// coordinates within 32-bit integers at the finest step; extras named like the standard
// attributes (intensity, classification, gps_time, red, ...) fill those fields. Normals go into
// extra-bytes fields NormalX, NormalY, NormalZ (float32, the names PDAL and CloudCompare read);
// other extras become extra-bytes fields of their type. LAZ: the same records compressed by the
// laz crate (core/rust).
#include "io/formats_ffi.hpp"
#include "io/las.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace nhnet::io_detail {
namespace {

/// The file being built.
struct LasOut {
  std::string header;
  uint8_t format = 6;
  size_t record_length = 0;
  std::vector<LasVlr> vlrs;
  std::vector<LasExtraField> extras;
  std::vector<LasVlr> evlrs;
  uint64_t old_evlr_start = 0;
  std::string records;
  std::array<double, 3> scale{}, offset{};
  std::vector<std::string> taken;  ///< extras already in the records (not added again)
  bool fresh = true;
};

std::string vlr_head(const char* user, uint16_t id, size_t length, const char* description) {
  std::string h(54, '\0');
  std::memcpy(&h[2], user, std::min<size_t>(std::strlen(user), 16));
  put_le<uint16_t>(&h[18], id);
  put_le<uint16_t>(&h[20], uint16_t(length));
  std::memcpy(&h[22], description, std::min<size_t>(std::strlen(description), 32));
  return h;
}

const ExtraProperty* find_extra(const Cloud& cloud, const char* name) {
  for (const ExtraProperty& e : cloud.extras)
    if (e.name == name) return &e;
  return nullptr;
}

/// Writes the integer X/Y/Z of row `i` into record `r`; OutputError when it does not fit.
void quantize(const std::string& path, const LasOut& out, const Cloud& cloud, Eigen::Index i,
              char* r) {
  for (int k = 0; k < 3; ++k) {
    const double x = cloud.points(i, k);
    const double q = std::round((x - out.offset[size_t(k)]) / out.scale[size_t(k)]);
    if (!(std::fabs(q) <= double(std::numeric_limits<int32_t>::max())))
      output_error(path, "point " + std::to_string(i) + ": coordinate " + std::to_string(x) +
                             " cannot be stored in LAS (non-finite or out of the 32-bit range "
                             "of the scale and offset)");
    put_le<int32_t>(r + 4 * k, int32_t(q));
  }
}

/// Scale and offset for a fresh file: offset the bounding-box centre, scale the power of ten
/// that keeps every coordinate within 2^31 steps of it.
void choose_scale(const std::string& path, const Cloud& cloud, LasOut& out) {
  for (int k = 0; k < 3; ++k) {
    double lo = INFINITY, hi = -INFINITY;
    for (Eigen::Index i = 0; i < cloud.size(); ++i) {
      const double v = cloud.points(i, k);
      if (!std::isfinite(v))
        output_error(path, "point " + std::to_string(i) + " is not finite; LAS cannot store it");
      lo = std::min(lo, v), hi = std::max(hi, v);
    }
    if (cloud.size() == 0) lo = hi = 0;
    const double centre = 0.5 * (lo + hi), half = std::max(0.5 * (hi - lo), 1e-300);
    out.offset[size_t(k)] = centre;
    out.scale[size_t(k)] = std::pow(10.0, std::ceil(std::log10(half / 2e9)));
  }
}

/// A fresh LAS 1.4 header and records for `cloud` (X/Y/Z and the standard attributes).
void start_fresh(const std::string& path, const Cloud& cloud, LasOut& out) {
  const bool rgb =
      find_extra(cloud, "red") && find_extra(cloud, "green") && find_extra(cloud, "blue");
  out.format = rgb ? (find_extra(cloud, "nir") ? 8 : 7) : 6;
  out.record_length = las_standard_size(out.format);
  out.header.assign(375, '\0');
  char* h = out.header.data();
  std::memcpy(h, "LASF", 4);
  put_le<uint16_t>(h + 6, 0x10);  // global encoding: CRS as WKT (required by formats 6-10)
  h[24] = 1, h[25] = 4;
  std::memcpy(h + 26, "nhnet", 5);
  std::memcpy(h + 58, "nhnet", 5);
  put_le<uint16_t>(h + 94, 375);
  choose_scale(path, cloud, out);
  out.records.assign(size_t(cloud.size()) * out.record_length, '\0');
  for (const LasAttribute& a : las_attributes(out.format)) {
    const ExtraProperty* e = find_extra(cloud, a.name);
    if (!e) continue;
    out.taken.emplace_back(a.name);
    for (Eigen::Index i = 0; i < cloud.size(); ++i) {
      char* r = out.records.data() + size_t(i) * out.record_length + a.offset;
      if (a.bits_mask) {
        const int v = int(std::clamp(e->values[size_t(i)], 0.0, double(a.bits_mask)));
        *r = char(uint8_t(*r) | uint8_t(v << a.bits_shift));
      } else {
        std::string bytes;
        encode_scalar_le(e->values[size_t(i)], a.type, bytes);
        std::memcpy(r, bytes.data(), bytes.size());
      }
    }
  }
  for (Eigen::Index i = 0; i < cloud.size(); ++i)
    quantize(path, out, cloud, i, out.records.data() + size_t(i) * out.record_length);
}

/// The input's header, VLRs, EVLRs and records; X/Y/Z re-quantized where a point moved.
void start_from_source(const std::string& path, const LasSource& src, const Cloud& cloud,
                       LasOut& out) {
  out.fresh = false;
  out.header = src.header;
  out.format = src.format;
  out.record_length = src.record_length;
  out.vlrs = src.vlrs;
  out.extras = src.extras;
  out.evlrs = src.evlrs;
  out.old_evlr_start = src.evlr_start;
  out.records = src.records;
  out.scale = src.scale;
  out.offset = src.offset;
  out.taken = src.read_names;
  for (Eigen::Index i = 0; i < cloud.size(); ++i) {
    char* r = out.records.data() + size_t(i) * out.record_length;
    for (int k = 0; k < 3; ++k) {
      const double was = get_le<int32_t>(r + 4 * k) * src.scale[size_t(k)] + src.offset[size_t(k)];
      if (!(was == cloud.points(i, k))) {
        quantize(path, out, cloud, i, r);
        break;
      }
    }
  }
}

uint8_t extra_type_code(ScalarType t) {
  switch (t) {
    case ScalarType::UInt8: return 1;
    case ScalarType::Int8: return 2;
    case ScalarType::UInt16: return 3;
    case ScalarType::Int16: return 4;
    case ScalarType::UInt32: return 5;
    case ScalarType::Int32: return 6;
    case ScalarType::Float32: return 9;
    case ScalarType::Float64: return 10;
  }
  return 10;
}

/// A column to add as an extra-bytes field.
struct NewField {
  std::string name;
  uint8_t type;
  const double* values;
  Eigen::Index stride;
};

/// A column (`values`, every `stride`-th) written into an existing float field of the records
/// named `lower` (compared lower-case), if there is one.
bool overwrite_field(const Cloud& cloud, const char* lower, const double* values,
                     Eigen::Index stride, LasOut& out) {
  for (const LasExtraField& f : out.extras) {
    std::string n = f.name;
    std::transform(n.begin(), n.end(), n.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    if (n != lower || (f.data_type != 9 && f.data_type != 10) || (f.descriptor[3] & 0x18)) continue;
    for (Eigen::Index i = 0; i < cloud.size(); ++i) {
      char* r = out.records.data() + size_t(i) * out.record_length + f.offset;
      if (f.data_type == 9)
        put_le<float>(r, float(values[i * stride]));
      else
        put_le<double>(r, values[i * stride]);
    }
    return true;
  }
  return false;
}

/// Extra-bytes fields to append: the normals (unless written in place) and the extras that are
/// not in the records yet.
std::vector<NewField> new_fields(const Cloud& cloud, LasOut& out) {
  std::vector<NewField> add;
  std::vector<std::string> used = out.taken;
  for (const LasExtraField& f : out.extras) used.push_back(f.name);
  if (cloud.has_normals()) {
    static const char* names[] = {"NormalX", "NormalY", "NormalZ"};
    static const char* lower[] = {"normalx", "normaly", "normalz"};
    for (int k = 0; k < 3; ++k) {
      if (!out.fresh && overwrite_field(cloud, lower[k], cloud.normals.data() + k, 3, out))
        continue;
      add.push_back({names[k], 9, cloud.normals.data() + k, 3});
      used.emplace_back(names[k]);
    }
  }
  if (cloud.confidence.size() != 0) {  // float32 extra bytes, as PDAL / CloudCompare read them
    used.emplace_back("Confidence");   // an input extra of that name is replaced
    if (out.fresh || !overwrite_field(cloud, "confidence", cloud.confidence.data(), 1, out))
      add.push_back({"Confidence", 9, cloud.confidence.data(), 1});
  }
  for (const ExtraProperty& e : cloud.extras) {
    if (e.name.size() > 32 || std::find(used.begin(), used.end(), e.name) != used.end()) continue;
    used.push_back(e.name);
    add.push_back({e.name, extra_type_code(e.type), e.values.data(), 1});
  }
  return add;
}

/// Widens the records by the new fields (documenting any undescribed bytes first).
void append_fields(const std::string& path, const Cloud& cloud, LasOut& out) {
  const std::vector<NewField> add = new_fields(cloud, out);
  if (add.empty()) return;
  size_t described = las_standard_size(out.format);
  for (const LasExtraField& f : out.extras) described = std::max(described, f.offset + f.size);
  for (size_t gap = out.record_length - described; gap > 0;) {
    const size_t n = std::min<size_t>(gap, 255);
    out.extras.push_back({las_extra_descriptor("", 0, uint8_t(n)), "", 0, described, n});
    described += n, gap -= n;
  }
  size_t length = out.record_length;
  for (const NewField& f : add) length += las_extra_type_size(f.type);
  if (length > 65535) output_error(path, "LAS point records would exceed 65535 bytes");
  std::string records(size_t(cloud.size()) * length, '\0');
  std::string bytes;
  ScalarType type = ScalarType::Float64;
  for (Eigen::Index i = 0; i < cloud.size(); ++i) {
    char* r = records.data() + size_t(i) * length;
    std::memcpy(r, out.records.data() + size_t(i) * out.record_length, out.record_length);
    size_t at = out.record_length;
    for (const NewField& f : add) {
      bytes.clear();
      las_extra_scalar(f.type, type);
      encode_scalar_le(f.values[i * f.stride], type, bytes);
      std::memcpy(r + at, bytes.data(), bytes.size());
      at += bytes.size();
    }
  }
  size_t at = out.record_length;
  for (const NewField& f : add) {
    out.extras.push_back(
        {las_extra_descriptor(f.name, f.type), f.name, f.type, at, las_extra_type_size(f.type)});
    at += las_extra_type_size(f.type);
  }
  out.records = std::move(records);
  out.record_length = length;
}

/// Patches the header's sizes, counts, bounds and offsets for `out` (EVLRs: patch_evlr_start).
void patch_header(LasOut& out, size_t point_offset, bool compressed) {
  char* h = out.header.data();
  const uint64_t n = out.records.size() / out.record_length;
  const int minor = h[25];
  h[104] = char(out.format | (compressed ? 0x80 : 0));
  put_le<uint16_t>(h + 105, uint16_t(out.record_length));
  put_le<uint32_t>(h + 96, uint32_t(point_offset));
  put_le<uint32_t>(h + 100, uint32_t(out.vlrs.size()));
  put_le<uint32_t>(h + 107, out.format < 6 && n <= UINT32_MAX ? uint32_t(n) : 0);
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
  for (uint64_t i = 0; i < n; ++i)
    for (size_t k = 0; k < 3; ++k) {
      const double v =
          get_le<int32_t>(out.records.data() + i * out.record_length + 4 * k) * out.scale[k] +
          out.offset[k];
      lo[k] = i ? std::min(lo[k], v) : v, hi[k] = i ? std::max(hi[k], v) : v;
    }
  for (size_t k = 0; k < 3; ++k) {
    put_le<double>(h + 131 + 8 * k, out.scale[k]);
    put_le<double>(h + 155 + 8 * k, out.offset[k]);
    put_le<double>(h + 179 + 16 * k, hi[k]);
    put_le<double>(h + 187 + 16 * k, lo[k]);
  }
  if (out.fresh) {
    for (uint64_t i = 0; i < n; ++i) {
      const int ret = (uint8_t(out.records[i * out.record_length + 14]) & 15) - 1;
      if (ret >= 0 && ret < 15)
        put_le<uint64_t>(h + 255 + 8 * ret, get_le<uint64_t>(h + 255 + 8 * ret) + 1);
    }
  }
  if (minor >= 4) {
    put_le<uint32_t>(h + 243, uint32_t(out.evlrs.size()));
    put_le<uint64_t>(h + 247, n);
  }
}

/// Points the header `h` (patched by patch_header) at EVLRs starting at `evlr_start`; the
/// waveform data record (LAS 1.3+) moves with them.
void patch_evlr_start(const LasOut& out, char* h, uint64_t evlr_start) {
  const int minor = h[25];
  const uint64_t waveform = minor >= 3 ? get_le<uint64_t>(out.header.data() + 227) : 0;
  if (waveform && out.old_evlr_start && waveform >= out.old_evlr_start)
    put_le<uint64_t>(h + 227, waveform - out.old_evlr_start + evlr_start);
  if (minor >= 4) put_le<uint64_t>(h + 235, out.evlrs.empty() ? 0 : evlr_start);
}

/// The extra-bytes VLR (when there are fields) and, for LAZ, the laszip VLR; returns the
/// laszip payload ("" for LAS).
std::string finish_vlrs(const std::string& path, LasOut& out, bool compressed) {
  if (!out.extras.empty()) {
    std::string payload;
    for (const LasExtraField& f : out.extras) payload += f.descriptor;
    if (payload.size() > 65535) output_error(path, "too many extra-bytes fields for one VLR");
    out.vlrs.push_back({vlr_head("LASF_Spec", 4, payload.size(), "extra bytes"), payload});
  }
  if (!compressed) return "";
  RustBuf vlr;
  char err[512] = {0};
  const size_t extra = out.record_length - las_standard_size(out.format);
  if (nhnet_laz_vlr(out.format, uint16_t(extra), &vlr.buf, err, sizeof(err)) != 0)
    output_error(path, std::string("LAZ: ") + err);
  std::string payload(reinterpret_cast<const char*>(vlr.buf.ptr), vlr.buf.len);
  out.vlrs.push_back(
      {vlr_head("laszip encoded", 22204, payload.size(), "nhnet (laz crate)"), payload});
  return payload;
}

}  // namespace

void write_las(Sink& sink, const Cloud& cloud, bool compressed, const std::string& path) {
  LasOut out;
  const LasSource* src = cloud.las_source.get();
  if (src && src->record_length && src->records.size() / src->record_length == size_t(cloud.size()))
    start_from_source(path, *src, cloud, out);
  else
    start_fresh(path, cloud, out);
  append_fields(path, cloud, out);
  const std::string laszip = finish_vlrs(path, out, compressed);
  size_t point_offset = out.header.size();
  for (const LasVlr& v : out.vlrs) point_offset += v.head.size() + v.payload.size();
  if (point_offset > UINT32_MAX) output_error(path, "LAS header and VLRs exceed 4 GiB");
  patch_header(out, point_offset, compressed);
  std::string bytes = out.header;
  for (const LasVlr& v : out.vlrs) bytes += v.head + v.payload;
  if (!compressed) {
    patch_evlr_start(out, bytes.data(), point_offset + out.records.size());
    sink.write(bytes);
    sink.write(out.records);
  } else {
    RustBuf data;
    char err[512] = {0};
    if (nhnet_laz_compress(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size(),
                           reinterpret_cast<const uint8_t*>(laszip.data()), laszip.size(),
                           reinterpret_cast<const uint8_t*>(out.records.data()), out.records.size(),
                           &data.buf, err, sizeof(err)) != 0)
      output_error(path, std::string("LAZ: ") + err);
    if (data.buf.len < out.header.size()) output_error(path, "LAZ: compressor returned no data");
    patch_evlr_start(out, reinterpret_cast<char*>(data.buf.ptr), data.buf.len);
    sink.write(reinterpret_cast<const char*>(data.buf.ptr), data.buf.len);
  }
  for (const LasVlr& v : out.evlrs) sink.write(v.head + v.payload);
}

}  // namespace nhnet::io_detail
