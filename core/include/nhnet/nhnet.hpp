// The whole public API of the nhnet core in one include, for programs that want everything:
// reading and writing clouds, the estimation pipeline (PCA, MFPS, NH-Net), orientation,
// denoising and the error metrics. Each room's header can also be included on its own
// (docs/design/architecture.md lists the rooms).
#pragma once

#include "nhnet/denoise/denoise.hpp"
#include "nhnet/errors.hpp"
#include "nhnet/eval/metrics.hpp"
#include "nhnet/io/io.hpp"
#include "nhnet/orient/auto.hpp"
#include "nhnet/orient/orient.hpp"
#include "nhnet/pipeline/describe.hpp"
#include "nhnet/pipeline/estimate.hpp"
#include "nhnet/pipeline/estimate_oriented.hpp"
#include "nhnet/pipeline/stream.hpp"
#include "nhnet/pipeline/tiles.hpp"
#include "nhnet/progress.hpp"
#include "nhnet/types.hpp"
#include "nhnet/version.hpp"
