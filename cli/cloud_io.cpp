// Output path checks, and reading / writing the commands' clouds through nhnet's io.
#include "cloud_io.hpp"

#include "nhnet/errors.hpp"
#include "nhnet/io/io.hpp"
#include "progress.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

namespace nhcli {

namespace fs = std::filesystem;

void check_output(const std::string& in, const std::string& out, bool overwrite) {
  std::error_code ec;
  const fs::path out_path(out), in_path(in);
  const fs::file_status st = fs::status(out_path, ec);
  if (fs::exists(st)) {
    if (fs::is_directory(st)) throw nhnet::OutputError(out + ": is a directory");
    std::error_code ec2;
    if (fs::exists(in_path, ec2) && fs::equivalent(in_path, out_path, ec2) && !ec2)
      throw nhnet::OutputError("refusing to overwrite the input " + in +
                               " (choose another output path)");
    if (!overwrite)
      throw nhnet::OutputError(out + " already exists (use --overwrite to replace it)");
  }
  fs::path dir = out_path.parent_path();
  if (dir.empty()) dir = ".";
  const fs::file_status dst = fs::status(dir, ec);
  if (!fs::exists(dst))
    throw nhnet::OutputError("cannot write " + out + ": directory " + dir.string() +
                             " does not exist");
  if (!fs::is_directory(dst))
    throw nhnet::OutputError("cannot write " + out + ": " + dir.string() + " is not a directory");
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    throw nhnet::OutputError("cannot write " + out + ": directory " + dir.string() + ": " +
                             std::strerror(errno));
}

void check_output_format(const std::string& out) {
  if (nhnet::format_from_extension(out) == nhnet::FileFormat::Auto)
    throw nhnet::InvalidOptions("cannot tell the output format from the extension of " + out +
                                " (use .ply, .pcd, .xyz, .xyzn, .txt, .las, .laz or .e57)");
}

nhnet::Cloud read_input(Reporter& rep, const std::string& in, std::vector<std::string>& warnings) {
  rep.stage("reading");
  nhnet::Cloud cloud = nhnet::read_cloud(in, {}, &warnings);
  for (const auto& w : warnings) rep.warn(w);
  return cloud;
}

void write_output(Reporter& rep, const std::string& out, const nhnet::Cloud& cloud, bool ascii) {
  nhnet::WriteOptions wopt;
  wopt.ascii = ascii;
  rep.stage("writing", 1.0);
  nhnet::write_cloud(out, cloud, wopt);
  rep.clear();
}

}  // namespace nhcli
