// LAS 1.0-1.4 and LAZ reader (the writer is las_write.cpp): public header, VLRs, EVLRs, point
// formats 0-10, LAZ points decompressed by the laz crate (core/rust, formats_ffi.hpp).
//
// Points become doubles (X * scale + offset); the standard attributes (intensity,
// classification, GPS time, RGB, NIR, ...) and the extra-bytes fields become extras, extra-bytes
// fields NormalX/NormalY/NormalZ become the input normals. The header, the VLRs, the EVLRs and
// every raw point record are kept in Cloud::las_source, so that writing LAS/LAZ again passes
// each attribute (waveform fields and unknown bytes included) through bit-exact. A LAS file
// names no sensor: the cloud is marked airborne (normals face up when orienting Auto). Every
// count and offset is checked against the file size before anything is allocated.
#include "io/las.hpp"

#include "io/formats_ffi.hpp"

#include <algorithm>
#include <cctype>
#include <memory>

namespace nhnet::io_detail {

size_t las_standard_size(uint8_t format) {
  static const size_t sizes[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  return format <= 10 ? sizes[format] : 0;
}

size_t las_extra_type_size(uint8_t t) {
  static const size_t sizes[] = {0, 1, 1, 2, 2, 4, 4, 8, 8, 4, 8};
  return t <= 10 ? sizes[t] : 0;
}

bool las_extra_scalar(uint8_t t, ScalarType& type) {
  static const ScalarType types[] = {ScalarType::UInt8,   ScalarType::UInt8,   ScalarType::Int8,
                                     ScalarType::UInt16,  ScalarType::Int16,   ScalarType::UInt32,
                                     ScalarType::Int32,   ScalarType::Float64, ScalarType::Float64,
                                     ScalarType::Float32, ScalarType::Float64};
  if (t < 1 || t > 10) return false;
  type = types[t];
  return true;
}

std::string las_extra_descriptor(const std::string& name, uint8_t data_type,
                                 uint8_t undocumented_size) {
  std::string d(192, '\0');
  d[2] = char(data_type);
  d[3] = char(undocumented_size);  // options; for type 0 the byte count
  std::memcpy(&d[4], name.data(), std::min<size_t>(name.size(), 32));
  return d;
}

std::vector<LasAttribute> las_attributes(uint8_t format) {
  using S = ScalarType;
  std::vector<LasAttribute> a = {{"intensity", S::UInt16, 12}};
  const bool legacy = format < 6;
  if (legacy) {
    a.push_back({"return_number", S::UInt8, 14, 0, 7});
    a.push_back({"number_of_returns", S::UInt8, 14, 3, 7});
    a.push_back({"classification", S::UInt8, 15, 0, 31});
    a.push_back({"scan_angle", S::Int8, 16});
    a.push_back({"user_data", S::UInt8, 17});
    a.push_back({"point_source_id", S::UInt16, 18});
  } else {
    a.push_back({"return_number", S::UInt8, 14, 0, 15});
    a.push_back({"number_of_returns", S::UInt8, 14, 4, 15});
    a.push_back({"classification", S::UInt8, 16});
    a.push_back({"user_data", S::UInt8, 17});
    a.push_back({"scan_angle", S::Int16, 18});
    a.push_back({"point_source_id", S::UInt16, 20});
    a.push_back({"gps_time", S::Float64, 22});
  }
  if (format == 1 || format == 3 || format == 4 || format == 5)
    a.push_back({"gps_time", S::Float64, 20});
  size_t rgb = 0;
  if (format == 2) rgb = 20;
  if (format == 3 || format == 5) rgb = 28;
  if (format == 7 || format == 8 || format == 10) rgb = 30;
  if (rgb) {
    a.push_back({"red", S::UInt16, rgb});
    a.push_back({"green", S::UInt16, rgb + 2});
    a.push_back({"blue", S::UInt16, rgb + 4});
  }
  if (format == 8 || format == 10) a.push_back({"nir", S::UInt16, 36});
  return a;
}

namespace {

constexpr size_t kMinHeader = 227;  // LAS 1.0-1.2 public header
constexpr size_t kVlrHead = 54;
constexpr size_t kEvlrHead = 60;

/// The header fields the reader needs.
struct LasHeader {
  int minor = 0;
  size_t header_size = 0;
  uint64_t point_offset = 0;
  uint32_t vlr_count = 0;
  uint8_t format = 0;
  bool compressed = false;
  size_t record_length = 0;
  uint64_t count = 0;
  uint64_t evlr_start = 0;
  uint64_t evlr_count = 0;
  std::array<double, 3> scale{}, offset{};
};

std::string at_byte(uint64_t b) { return " (byte " + std::to_string(b) + ")"; }

LasHeader parse_header(const FileBytes& file) {
  const std::string& b = file.bytes;
  if (b.size() < kMinHeader)
    input_error(file.path, "truncated LAS header: " + std::to_string(b.size()) +
                               " bytes, at least " + std::to_string(kMinHeader) + " needed");
  LasHeader h;
  const char* p = b.data();
  if (p[24] != 1 || p[25] < 0 || p[25] > 4)
    input_error(file.path, "unsupported LAS version " + std::to_string(int(p[24])) + "." +
                               std::to_string(int(p[25])));
  h.minor = p[25];
  h.header_size = get_le<uint16_t>(p + 94);
  const size_t need = h.minor >= 4 ? 375 : h.minor == 3 ? 235 : kMinHeader;
  if (h.header_size < need || h.header_size > b.size())
    input_error(file.path, "bad LAS header size " + std::to_string(h.header_size) + " (LAS 1." +
                               std::to_string(h.minor) + " needs " + std::to_string(need) +
                               ", file has " + std::to_string(b.size()) + " bytes)");
  h.point_offset = get_le<uint32_t>(p + 96);
  h.vlr_count = get_le<uint32_t>(p + 100);
  const uint8_t f = uint8_t(p[104]);
  h.compressed = (f & 0xC0) != 0;
  h.format = f & 0x3F;
  if (h.format > 10)
    input_error(file.path, "unknown LAS point format " + std::to_string(int(h.format)) +
                               " (0..10 are defined)");
  h.record_length = get_le<uint16_t>(p + 105);
  if (h.record_length < las_standard_size(h.format))
    input_error(file.path, "point record length " + std::to_string(h.record_length) +
                               " is shorter than point format " + std::to_string(int(h.format)) +
                               " needs (" + std::to_string(las_standard_size(h.format)) + ")");
  h.count = get_le<uint32_t>(p + 107);
  for (int k = 0; k < 3; ++k) {
    h.scale[size_t(k)] = get_le<double>(p + 131 + 8 * k);
    h.offset[size_t(k)] = get_le<double>(p + 155 + 8 * k);
    if (!std::isfinite(h.scale[size_t(k)]) || h.scale[size_t(k)] == 0 ||
        !std::isfinite(h.offset[size_t(k)]))
      input_error(file.path, "bad scale or offset of coordinate " + std::string(1, "XYZ"[k]));
  }
  if (h.minor == 3) h.evlr_start = get_le<uint64_t>(p + 227), h.evlr_count = h.evlr_start ? 1 : 0;
  if (h.minor >= 4) {
    h.evlr_start = get_le<uint64_t>(p + 235);
    h.evlr_count = get_le<uint32_t>(p + 243);
    const uint64_t count64 = get_le<uint64_t>(p + 247);
    if (count64 != 0) h.count = count64;
  }
  if (h.point_offset < h.header_size || h.point_offset > b.size())
    input_error(file.path, "offset to point data " + std::to_string(h.point_offset) +
                               " lies outside the file (" + std::to_string(b.size()) + " bytes)");
  return h;
}

/// Parses `count` records with `head_size`-byte headers from `pos`, up to `end`.
std::vector<LasVlr> parse_records(const FileBytes& file, uint64_t pos, uint64_t end, uint64_t count,
                                  size_t head_size, const char* what) {
  std::vector<LasVlr> out;
  for (uint64_t i = 0; i < count; ++i) {
    if (pos + head_size > end || end > file.bytes.size())
      input_error(file.path, std::string(what) + " " + std::to_string(i) + " of " +
                                 std::to_string(count) + " runs past its section" + at_byte(pos));
    const char* p = file.bytes.data() + pos;
    const uint64_t len =
        head_size == kVlrHead ? get_le<uint16_t>(p + 20) : get_le<uint64_t>(p + 20);
    if (len > end - pos - head_size)
      input_error(file.path, std::string(what) + " " + std::to_string(i) + " declares " +
                                 std::to_string(len) + " bytes, more than the file holds" +
                                 at_byte(pos));
    out.push_back({std::string(p, head_size), std::string(p + head_size, size_t(len))});
    pos += head_size + len;
  }
  return out;
}

bool is_vlr(const LasVlr& v, const char* user, uint16_t id) {
  return v.head.compare(2, std::strlen(user), user) == 0 &&
         (std::strlen(user) == 16 || v.head[2 + std::strlen(user)] == '\0') &&
         get_le<uint16_t>(v.head.data() + 18) == id;
}

/// The extra-bytes fields from the descriptors of `vlr`, placed after the standard fields.
std::vector<LasExtraField> parse_extra_fields(const FileBytes& file, const LasVlr& vlr,
                                              const LasHeader& h) {
  std::vector<LasExtraField> out;
  size_t offset = las_standard_size(h.format);
  for (size_t pos = 0; pos + 192 <= vlr.payload.size(); pos += 192) {
    LasExtraField f;
    f.descriptor = vlr.payload.substr(pos, 192);
    const char* d = f.descriptor.data();
    f.data_type = uint8_t(d[2]);
    f.name = std::string(d + 4, strnlen(d + 4, 32));
    if (f.data_type == 0) {
      f.size = uint8_t(d[3]);
    } else if (f.data_type <= 10) {
      f.size = las_extra_type_size(f.data_type);
    } else if (f.data_type <= 30) {
      f.size =
          las_extra_type_size(uint8_t((f.data_type - 1) % 10 + 1)) * ((f.data_type - 1) / 10 + 1);
    } else {
      input_error(file.path, "extra-bytes field '" + f.name + "' has unknown data type " +
                                 std::to_string(int(f.data_type)));
    }
    f.offset = offset;
    offset += f.size;
    if (offset > h.record_length)
      input_error(file.path, "extra-bytes fields need " + std::to_string(offset) +
                                 " bytes per point, the records have " +
                                 std::to_string(h.record_length));
    out.push_back(std::move(f));
  }
  return out;
}

/// The uncompressed point records: a slice of the file, or the decompressed LAZ data.
std::string load_records(const FileBytes& file, const LasHeader& h, const LasVlr* laszip) {
  const uint64_t avail = file.bytes.size() - h.point_offset;
  const std::string declared = "header declares " + std::to_string(h.count) + " points of " +
                               std::to_string(h.record_length) + " bytes";
  if (!h.compressed) {
    if (h.count > avail / h.record_length)
      input_error(file.path, declared + " from byte " + std::to_string(h.point_offset) +
                                 ", the file holds " + std::to_string(avail / h.record_length) +
                                 " (truncated?)");
    return file.bytes.substr(size_t(h.point_offset), size_t(h.count * h.record_length));
  }
  if (!laszip) input_error(file.path, "compressed points (LAZ) without a laszip VLR");
  // LASzip cannot compress a point below a few bits: bound the allocation by the data size.
  if (h.count > kMaxCount || h.count * h.record_length > 4096 * avail + 65536)
    input_error(file.path,
                declared + ", more than " + std::to_string(avail) + " compressed bytes can hold");
  std::string records(size_t(h.count * h.record_length), '\0');
  char err[512] = {0};
  if (nhnet_laz_decompress(reinterpret_cast<const uint8_t*>(file.bytes.data()), file.bytes.size(),
                           reinterpret_cast<const uint8_t*>(laszip->payload.data()),
                           laszip->payload.size(), h.point_offset,
                           reinterpret_cast<uint8_t*>(records.data()), records.size(), err,
                           sizeof(err)) != 0)
    input_error(file.path, std::string("LAZ: ") + err);
  return records;
}

/// Reads a scalar of extra-bytes type `t` (1..10) at `p`.
double extra_value(const char* p, uint8_t t) {
  switch (t) {
    case 1: return uint8_t(*p);
    case 2: return int8_t(*p);
    case 3: return get_le<uint16_t>(p);
    case 4: return get_le<int16_t>(p);
    case 5: return get_le<uint32_t>(p);
    case 6: return get_le<int32_t>(p);
    case 7: return double(get_le<uint64_t>(p));
    case 8: return double(get_le<int64_t>(p));
    case 9: return get_le<float>(p);
    default: return get_le<double>(p);
  }
}

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

/// Index 0..2 when `name` names a normal component (NormalX, normal_x, nx, ...), else -1.
int normal_component(const std::string& name) {
  const std::string n = lower(name);
  for (int k = 0; k < 3; ++k) {
    const std::string axis(1, "xyz"[k]);
    if (n == "normal" + axis || n == "normal_" + axis || n == "n" + axis) return k;
  }
  return -1;
}

/// Fills points, extras and normals of `cloud` from the records of `src`.
void decode_points(const LasSource& src, Cloud& cloud) {
  const Eigen::Index n = Eigen::Index(src.records.size() / src.record_length);
  cloud.points.resize(n, 3);
  const std::vector<LasAttribute> attrs = las_attributes(src.format);
  std::vector<const LasExtraField*> fields;
  int normal_fields[3] = {-1, -1, -1};
  for (const LasExtraField& f : src.extras) {
    if (f.data_type < 1 || f.data_type > 10 || f.name.empty()) continue;
    const int k = normal_component(f.name);
    if (k >= 0 && normal_fields[k] < 0) normal_fields[k] = int(fields.size());
    fields.push_back(&f);
  }
  const bool normals = normal_fields[0] >= 0 && normal_fields[1] >= 0 && normal_fields[2] >= 0;
  if (normals) cloud.normals.resize(n, 3);
  for (const LasAttribute& a : attrs)
    cloud.extras.push_back({a.name, a.type, std::vector<double>(size_t(n))});
  std::vector<int> field_extra(fields.size(), -1);
  for (size_t j = 0; j < fields.size(); ++j) {
    if (normals &&
        (int(j) == normal_fields[0] || int(j) == normal_fields[1] || int(j) == normal_fields[2]))
      continue;
    ScalarType t = ScalarType::Float64;
    const bool scaled = (uint8_t(fields[j]->descriptor[3]) & 0x18) != 0;
    if (!scaled) las_extra_scalar(fields[j]->data_type, t);
    field_extra[j] = int(cloud.extras.size());
    cloud.extras.push_back({fields[j]->name, t, std::vector<double>(size_t(n))});
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const char* r = src.records.data() + size_t(i) * src.record_length;
    for (int k = 0; k < 3; ++k)
      cloud.points(i, k) =
          get_le<int32_t>(r + 4 * k) * src.scale[size_t(k)] + src.offset[size_t(k)];
    for (size_t j = 0; j < attrs.size(); ++j) {
      const LasAttribute& a = attrs[j];
      double v = decode_scalar(reinterpret_cast<const unsigned char*>(r + a.offset), a.type, false);
      if (a.bits_mask) v = double((int(v) >> a.bits_shift) & a.bits_mask);
      cloud.extras[j].values[size_t(i)] = v;
    }
    for (size_t j = 0; j < fields.size(); ++j) {
      const LasExtraField& f = *fields[j];
      double v = extra_value(r + f.offset, f.data_type);
      const uint8_t options = uint8_t(f.descriptor[3]);
      if (options & 0x08) v *= get_le<double>(f.descriptor.data() + 112);
      if (options & 0x10) v += get_le<double>(f.descriptor.data() + 136);
      if (field_extra[j] >= 0) cloud.extras[size_t(field_extra[j])].values[size_t(i)] = v;
      for (int k = 0; k < 3; ++k)
        if (normals && normal_fields[k] == int(j)) cloud.normals(i, k) = v;
    }
  }
}

}  // namespace

Cloud read_las(const FileBytes& file, std::vector<std::string>* warnings) {
  const LasHeader h = parse_header(file);
  auto src = std::make_shared<LasSource>();
  src->header = file.bytes.substr(0, h.header_size);
  const LasVlr* laszip = nullptr;
  std::vector<LasVlr> vlrs =
      parse_records(file, h.header_size, h.point_offset, h.vlr_count, kVlrHead, "VLR");
  for (const LasVlr& v : vlrs) {
    if (is_vlr(v, "laszip encoded", 22204))
      laszip = &v;
    else if (is_vlr(v, "LASF_Spec", 4))
      src->extras = parse_extra_fields(file, v, h);
  }
  std::copy_if(vlrs.begin(), vlrs.end(), std::back_inserter(src->vlrs), [](const LasVlr& v) {
    return !is_vlr(v, "laszip encoded", 22204) && !is_vlr(v, "LASF_Spec", 4);
  });
  if (h.evlr_count > 0) {
    if (h.evlr_start < h.point_offset || h.evlr_start > file.bytes.size())
      input_error(file.path, "EVLRs start at byte " + std::to_string(h.evlr_start) +
                                 ", outside the file (" + std::to_string(file.bytes.size()) +
                                 " bytes)");
    src->evlrs =
        parse_records(file, h.evlr_start, file.bytes.size(), h.evlr_count, kEvlrHead, "EVLR");
    src->evlr_start = h.evlr_start;
  }
  src->format = h.format;
  src->record_length = h.record_length;
  src->scale = h.scale;
  src->offset = h.offset;
  src->records = load_records(file, h, laszip);
  Cloud cloud;
  decode_points(*src, cloud);
  for (const ExtraProperty& e : cloud.extras) src->read_names.push_back(e.name);
  if (h.compressed && h.minor < 4 && h.format > 5)
    warn(warnings, "LAZ point format " + std::to_string(int(h.format)) + " in a LAS 1." +
                       std::to_string(h.minor) + " header");
  cloud.airborne = true;
  cloud.las_source = std::move(src);
  return cloud;
}

}  // namespace nhnet::io_detail
