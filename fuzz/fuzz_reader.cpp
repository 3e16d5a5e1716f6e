// libFuzzer target for one point cloud reader (chosen by NHNET_FUZZ_FORMAT at compile time:
// 0 = PLY, 1 = PCD, 2 = XYZ, 3 = LAS/LAZ, 4 = E57). Feeds the bytes from memory (no temporary
// file).
// Properties checked on every input:
//   - the reader either returns a cloud or throws nhnet::InputError (anything else escapes and
//     libFuzzer reports it as a crash; ASan/UBSan report memory errors, -rss_limit_mb and
//     -timeout turn huge allocations and hangs into failures);
//   - a cloud that was read writes (binary and ascii where the format has both) and reads back
//     with the same point count and bit-identical coordinates (NaN equal to NaN); LAS: as LAS
//     and as LAZ ("ascii" selects LAZ), where a writer's OutputError (e.g. a point format the
//     LAZ compressor lacks) ends the round trip; E57: written only (poses re-applied round).
#include "io/detail.hpp"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>

#ifndef NHNET_FUZZ_FORMAT
#error "define NHNET_FUZZ_FORMAT (0 = PLY, 1 = PCD, 2 = XYZ, 3 = LAS/LAZ, 4 = E57)"
#endif

namespace {

using namespace nhnet;
using namespace nhnet::io_detail;

struct StringSink final : Sink {
  std::string data;
  void write(const char* d, size_t n) override { data.append(d, n); }
};

Cloud read(const FileBytes& f) {
#if NHNET_FUZZ_FORMAT == 0
  return read_ply(f, nullptr);
#elif NHNET_FUZZ_FORMAT == 1
  return read_pcd(f, nullptr);
#elif NHNET_FUZZ_FORMAT == 2
  return read_xyz(f, nullptr);
#elif NHNET_FUZZ_FORMAT == 3
  return read_las(f, nullptr);
#else
  return read_e57(f, nullptr);
#endif
}

void write(Sink& sink, const Cloud& c, bool ascii) {
#if NHNET_FUZZ_FORMAT == 0
  write_ply(sink, c, ascii);
#elif NHNET_FUZZ_FORMAT == 1
  write_pcd(sink, c, ascii);
#elif NHNET_FUZZ_FORMAT == 2
  (void)ascii;
  write_xyz(sink, c);
#elif NHNET_FUZZ_FORMAT == 3
  write_las(sink, c, ascii, "roundtrip");
#else
  (void)ascii;
  write_e57(sink, c, "roundtrip");
#endif
}

bool same(double a, double b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

/// Writes `c`, reads it back and aborts when the points differ.
void round_trip(const Cloud& c, bool ascii) {
  StringSink sink;
  try {
    write(sink, c, ascii);
  } catch (const OutputError&) {
    if (NHNET_FUZZ_FORMAT < 3) throw;
    return;
  }
  if (NHNET_FUZZ_FORMAT == 4) return;
  Cloud back;
  try {
    back = read(FileBytes{"roundtrip", sink.data});
  } catch (const InputError& e) {
    // An empty cloud written as XYZ has no lines, which the XYZ reader refuses: fine.
    if (c.size() == 0) return;
    std::fprintf(stderr, "round trip (ascii=%d) of a %ld-point cloud failed: %s\n", int(ascii),
                 long(c.size()), e.what());
    std::abort();
  }
  if (back.size() != c.size()) {
    std::fprintf(stderr, "round trip changed the point count %ld -> %ld\n", long(c.size()),
                 long(back.size()));
    std::abort();
  }
  for (Eigen::Index i = 0; i < c.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!same(c.points(i, k), back.points(i, k))) {
        std::fprintf(stderr,
                     "round trip (ascii=%d) changed point %ld coordinate %d: %.17g -> %.17g\n",
                     int(ascii), long(i), k, c.points(i, k), back.points(i, k));
        std::abort();
      }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const FileBytes file{"fuzz", std::string(reinterpret_cast<const char*>(data), size)};
  Cloud cloud;
  try {
    cloud = read(file);
  } catch (const InputError&) {
    return 0;  // refused cleanly: the expected outcome for most inputs
  }
  round_trip(cloud, false);
  if (NHNET_FUZZ_FORMAT != 2 && NHNET_FUZZ_FORMAT != 4) round_trip(cloud, true);
  return 0;
}
