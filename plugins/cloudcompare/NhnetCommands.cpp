// -NHNET_NORMALS / -NHNET_DENOISE (see NhnetCommands.h). Options are read from the front of the
// argument list until the first token that is not one of this command's options; a missing or
// malformed value is an error naming the option.
#include "NhnetCommands.h"

#include "NhnetAdapter.h"

#include <ccProgressDialog.h>

#include <functional>
#include <type_traits>

namespace nhcc {

namespace {

const char kNormals[] = "NHNET_NORMALS";
const char kDenoise[] = "NHNET_DENOISE";

/// Takes the value after `option`; throws nhnet::InvalidOptions when there is none.
QString take_value(ccCommandLineInterface& cmd, const char* option) {
  if (cmd.arguments().empty())
    throw nhnet::InvalidOptions(std::string("missing value after -") + option);
  return cmd.arguments().takeFirst();
}

/// Takes a number after `option` (an integer when T is int); throws naming the option otherwise.
template <class T>
T take_number(ccCommandLineInterface& cmd, const char* option) {
  const QString v = take_value(cmd, option);
  bool ok = false;
  const T x = std::is_integral<T>::value ? T(v.toInt(&ok)) : T(v.toDouble(&ok));
  if (!ok)
    throw nhnet::InvalidOptions(
        std::string("-") + option +
        (std::is_integral<T>::value ? " needs an integer" : " needs a number") + ", got '" +
        v.toStdString() + "'");
  return x;
}

/// Consumes this command's options: `handle(name)` returns false for a name it does not know,
/// which ends the options (the token is left for CloudCompare: it may be the next command).
void parse_options(ccCommandLineInterface& cmd, const std::function<bool(const QString&)>& handle) {
  while (!cmd.arguments().empty()) {
    const QString token = cmd.arguments().front();
    if (!token.startsWith('-')) break;
    const QString name = token.mid(1).toUpper();
    cmd.arguments().takeFirst();
    if (!handle(name)) {
      cmd.arguments().push_front(token);
      break;
    }
  }
}

/// Handles the estimation options shared by both commands; false for any other name.
bool normals_option(ccCommandLineInterface& cmd, const QString& name, NormalsSettings& s) {
  if (name == "METHOD") {
    s.method = take_value(cmd, "METHOD").toLower();
    s.fallback_why.clear();  // chosen, not the default: no fallback warning
  } else if (name == "SCALES") {
    s.scales = take_value(cmd, "SCALES");
  } else if (name == "THREADS") {
    s.threads = take_number<int>(cmd, "THREADS");
  } else if (name == "MODEL") {
    s.model = take_value(cmd, "MODEL");
  } else if (name == "PRECISION") {
    s.precision = take_value(cmd, "PRECISION");
  } else if (name == "CONFIDENCE") {
    const QString v = take_value(cmd, "CONFIDENCE").toUpper();
    if (v != "ON" && v != "OFF")
      throw nhnet::InvalidOptions("-CONFIDENCE takes ON or OFF, not " + v.toStdString());
    s.confidence = v == "ON";
  } else {
    return false;
  }
  return true;
}

/// Runs `fn` on every loaded cloud, saves each (unless -AUTO_SAVE OFF); false on the first error.
bool for_each_cloud(ccCommandLineInterface& cmd, const char* command, const char* suffix,
                    const std::function<Outcome(ccPointCloud&, const RunUi&)>& fn) {
  if (cmd.clouds().empty())
    return cmd.error(
        QString("[NH-Net] -%1: no cloud loaded (open one first with -O FILE)").arg(command));
  for (CLCloudDesc& desc : cmd.clouds()) {
    if (!desc.pc) continue;
    Outcome out;
    RunUi ui;
    ui.dialog = cmd.progressDialog();  // none in -SILENT runs: progress goes to the console
    ui.print = [&cmd](const QString& line) { cmd.print(line); };
    const QString error = guarded([&] { out = fn(*desc.pc, ui); });
    if (!error.isEmpty())
      return cmd.error(QString("[NH-Net] -%1 on '%2': %3").arg(command, desc.basename, error));
    for (const QString& w : out.warnings)
      cmd.warning(QString("[NH-Net] '%1': %2").arg(desc.basename, w));
    cmd.print(QString("[NH-Net] '%1': %2").arg(desc.basename, out.summary));
    if (cmd.autoSaveMode()) {
      const QString saveError = cmd.exportEntity(desc, suffix);
      if (!saveError.isEmpty()) return cmd.error(saveError);
    }
  }
  return true;
}

/// Option errors become CloudCompare errors (exit 1) before any cloud is touched.
bool parse_guarded(ccCommandLineInterface& cmd, const char* command,
                   const std::function<void()>& parse) {
  const QString error = guarded(parse);
  if (error.isEmpty()) return true;
  return cmd.error(QString("[NH-Net] -%1: %2").arg(command, error));
}

}  // namespace

CommandNormals::CommandNormals() : Command("NH-Net normals", kNormals) {}

bool CommandNormals::process(ccCommandLineInterface& cmd) {
  cmd.print("[NH-Net] estimating normals");
  NormalsSettings s;
  const bool ok = parse_guarded(cmd, kNormals, [&] {
    parse_options(cmd, [&](const QString& name) {
      if (normals_option(cmd, name, s)) return true;
      if (name != "ORIENT") return false;
      s.orient = orient_from_string(take_value(cmd, "ORIENT"));
      if (s.orient == nhnet::OrientMode::Viewpoint)
        for (double& v : s.viewpoint) v = take_number<double>(cmd, "ORIENT viewpoint");
      return true;
    });
  });
  if (!ok) return false;
  return for_each_cloud(cmd, kNormals, "NHNET_NORMALS", [&](ccPointCloud& c, const RunUi& ui) {
    return estimate_cloud_normals(c, s, ui);
  });
}

CommandDenoise::CommandDenoise() : Command("NH-Net normal-guided denoise", kDenoise) {}

bool CommandDenoise::process(ccCommandLineInterface& cmd) {
  cmd.print("[NH-Net] normal-guided denoise");
  DenoiseSettings s;
  const bool ok = parse_guarded(cmd, kDenoise, [&] {
    parse_options(cmd, [&](const QString& name) {
      // -METHOD would be ambiguous here: -NORMALS names the method that estimates the normals.
      if (name != "METHOD" && normals_option(cmd, name, s.estimate)) return true;
      if (name == "ITERATIONS") {
        s.iterations = take_number<int>(cmd, "ITERATIONS");
      } else if (name == "RADIUS") {
        s.radius = take_number<double>(cmd, "RADIUS");
      } else if (name == "NORMALS") {
        s.normals = take_value(cmd, "NORMALS").toLower();
      } else {
        return false;
      }
      return true;
    });
  });
  if (!ok) return false;
  return for_each_cloud(cmd, kDenoise, "NHNET_DENOISED",
                        [&](ccPointCloud& c, const RunUi& ui) { return denoise_cloud(c, s, ui); });
}

}  // namespace nhcc
