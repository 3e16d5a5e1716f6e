// estimate -o DIR: the batch's inputs (files, or the clouds in directories) and their outputs in
// DIR, run one after the other; a failing input is reported and the next one runs.
#include "estimate.hpp"

#include "cloud_io.hpp"
#include "errors.hpp"
#include "nhnet/errors.hpp"
#include "progress.hpp"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>

namespace nhcli {

namespace {

namespace fs = std::filesystem;

bool cloud_extension(const fs::path& p) {
  std::string e = p.extension().string();
  std::transform(e.begin(), e.end(), e.begin(),
                 [](unsigned char c) { return char(std::tolower(c)); });
  return e == ".ply" || e == ".pcd" || e == ".xyz" || e == ".xyzn" || e == ".txt";
}

/// The clouds in directory `dir` (by extension, sorted, not recursive).
std::vector<std::string> clouds_in(const std::string& dir) {
  std::error_code ec;
  std::vector<std::string> found;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    if (it->is_regular_file(ec) && cloud_extension(it->path()))
      found.push_back(it->path().string());
  if (ec) throw nhnet::InputError(dir + ": cannot list the directory: " + ec.message());
  std::sort(found.begin(), found.end());
  return found;
}

/// The batch's inputs: files as given, directories replaced by their clouds; each with its
/// output path in DIR.
std::vector<Outcome> batch_jobs(const EstimateArgs& a) {
  std::vector<std::string> inputs;
  for (const auto& f : a.files) {
    std::error_code ec;
    if (fs::is_directory(f, ec)) {
      const std::vector<std::string> found = clouds_in(f);
      inputs.insert(inputs.end(), found.begin(), found.end());
    } else {
      inputs.push_back(f);
    }
  }
  std::vector<Outcome> jobs;
  for (const auto& in : inputs) {
    Outcome o;
    o.in = in;
    const fs::path p(in);
    const std::string ext = a.ext.empty() ? p.extension().string() : "." + a.ext;
    o.out = (fs::path(a.out_dir) / (p.stem().string() + ext)).string();
    jobs.push_back(o);
  }
  return jobs;
}

/// Runs one job; a failure is recorded in `o` and printed (unless interrupted). Returns false
/// when the batch stops here (interrupted, or --fail-fast after a failure).
bool run_job(const EstimateArgs& a, const Setup& st, Reporter& rep,
             std::map<std::string, std::string>& claimed, Outcome& o) {
  try {
    if (a.ext.empty()) check_output_format(o.out);
    const auto [it, fresh] = claimed.emplace(o.out, o.in);
    if (!fresh)
      throw nhnet::OutputError("cannot write " + o.out + " for " + o.in + ": it is the output of " +
                               it->second);
    estimate_file(a, st, o);
    record_success(o);
    return true;
  } catch (...) {
    record_failure(o, /*name_input=*/true);
    const bool cancelled = is_signal_exit(o.exit_code);
    rep.clear();
    if (!cancelled) print_error(o.error);
    return !cancelled && !a.fail_fast;
  }
}

}  // namespace

int run_batch(const EstimateArgs& a, const Setup& st) {
  Reporter rep(a.output.quiet);
  std::vector<Outcome> jobs = batch_jobs(a);
  if (jobs.empty())
    throw nhnet::InputError("no input clouds (.ply, .pcd, .xyz, .xyzn, .txt) in " + a.files[0]);
  std::map<std::string, std::string> claimed;  // output -> the input writing it
  for (Outcome& o : jobs)
    if (interrupted() || !run_job(a, st, rep, claimed, o)) break;
  if (!a.report.empty()) write_report(a.report, st, jobs, rep.elapsed());
  return finish_batch(jobs);
}

}  // namespace nhcli
