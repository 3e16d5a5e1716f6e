// Command-line commands of the plugin (CloudCompare -SILENT ... ):
//   -NHNET_NORMALS [-METHOD mfps|pca] [-SCALES auto|50,100,150]
//                  [-ORIENT auto|keep|none|mst|viewpoint X Y Z]
//                  [-THREADS n] [-MODEL path] [-PRECISION auto|float32|bfloat16]
//                  [-CONFIDENCE ON|OFF]  (the scalar field "NH-Net confidence", default ON)
//   -NHNET_DENOISE [-ITERATIONS n] [-RADIUS r] [-NORMALS auto|input|mfps|pca] [-SCALES ..]
//   [-THREADS n]
// Both work on every loaded cloud, in place, and save them (suffix NHNET_NORMALS / NHNET_DENOISED)
// unless -AUTO_SAVE OFF. A bad option value or a failed cloud is an error (CloudCompare exits 1).
#pragma once

#include <ccCommandLineInterface.h>

namespace nhcc {

struct CommandNormals : public ccCommandLineInterface::Command {
  CommandNormals();
  bool process(ccCommandLineInterface& cmd) override;
};

struct CommandDenoise : public ccCommandLineInterface::Command {
  CommandDenoise();
  bool process(ccCommandLineInterface& cmd) override;
};

}  // namespace nhcc
