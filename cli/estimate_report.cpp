// estimate's outcomes per input: the --report JSON file and the batch's closing lines.
#include "estimate_report.hpp"

#include "errors.hpp"
#include "json.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/version.hpp"
#include "progress.hpp"

#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

namespace nhcli {

void record_success(Outcome& o) {
  o.status = "ok";
  o.exit_code = kOk;
}

void record_failure(Outcome& o, bool name_input) {
  std::string message;
  o.exit_code = classify_current_exception(message);
  if (name_input && message.find(o.in) == std::string::npos) message = o.in + ": " + message;
  o.error = one_line(message);
  o.status = is_signal_exit(o.exit_code) ? "interrupted" : "failed";
}

namespace {

/// How many outcomes are ok, failed and not run.
struct Tally {
  int ok = 0, failed = 0, not_run = 0;
};

Tally tally(const std::vector<Outcome>& outcomes) {
  Tally t;
  for (const auto& o : outcomes) {
    t.ok += o.status == "ok";
    t.failed += o.status == "failed";
  }
  t.not_run = int(outcomes.size()) - t.ok - t.failed;
  return t;
}

std::string json_or_null(const std::string& text) {
  return text.empty() ? "null" : json_string(text);
}

std::string count_or_null(int64_t n) { return n < 0 ? "null" : std::to_string(n); }

/// The report's text: the run's header, then one line per input.
std::string report_json(const Setup& st, const std::vector<Outcome>& outcomes, double seconds) {
  const Tally t = tally(outcomes);
  std::ostringstream js;
  js << "{\n  \"nhnet_version\": " << json_string(nhnet::version())
     << ",\n  \"method\": " << json_string(nhnet::to_string(st.opt.method))
     << ",\n  \"device\": " << json_string(st.device)
     << ",\n  \"precision\": " << json_string(st.precision)
     << ",\n  \"model\": " << json_or_null(st.model_path)
     << ",\n  \"model_sha256\": " << json_or_null(st.model_sha256)
     << ",\n  \"inputs\": " << outcomes.size() << ",\n  \"ok\": " << t.ok
     << ",\n  \"failed\": " << t.failed << ",\n  \"not_run\": " << t.not_run
     << ",\n  \"seconds\": " << json_number(seconds, 4) << ",\n  \"files\": [";
  for (size_t i = 0; i < outcomes.size(); ++i) {
    const Outcome& o = outcomes[i];
    js << (i ? ",\n" : "\n") << "    {\"input\": " << json_string(o.in)
       << ", \"output\": " << json_string(o.out) << ", \"status\": " << json_string(o.status)
       << ", \"exit_code\": " << count_or_null(o.exit_code)
       << ", \"error\": " << json_or_null(o.error) << ", \"points\": " << count_or_null(o.points)
       << ", \"invalid\": " << count_or_null(o.failed) << ", \"orient\": " << json_or_null(o.orient)
       << ", \"orient_source\": " << json_or_null(o.orient_source)
       << ", \"seconds\": " << json_number(o.seconds, 4) << "}";
  }
  js << "\n  ]\n}\n";
  return js.str();
}

}  // namespace

void write_report(const std::string& path, const Setup& st, const std::vector<Outcome>& outcomes,
                  double seconds) {
  const std::string tmp = path + ".nhnet-tmp";
  bool written = false;
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    f << report_json(st, outcomes, seconds);
    f.close();
    written = bool(f);
  }
  if (!written || std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw nhnet::OutputError("cannot write the report " + path);
  }
}

int finish_batch(const std::vector<Outcome>& outcomes) {
  const Tally t = tally(outcomes);
  std::string failures;
  for (const auto& o : outcomes)
    if (o.status == "failed")
      failures +=
          (failures.empty() ? "" : ", ") + o.in + " (exit " + std::to_string(o.exit_code) + ")";
  std::cerr << "nhnet-cli: batch: " << outcomes.size() << " inputs, " << t.ok << " ok, " << t.failed
            << " failed"
            << (t.not_run ? ", " + std::to_string(t.not_run) + " not run" : std::string())
            << (failures.empty() ? std::string() : "; failed: " + failures) << std::endl;
  if (const int sig = interrupted()) {
    print_error(std::string("interrupted (") + (sig == SIGTERM ? "SIGTERM" : "SIGINT") + "); the " +
                std::to_string(t.ok) +
                " outputs written before are complete, the rest were not written");
    return signal_exit_code(sig);
  }
  return t.failed > 0 ? kBatch : kOk;
}

}  // namespace nhcli
