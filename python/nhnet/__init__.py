"""nhnet: normal estimation for unstructured point clouds (CVPR 2020, "Geometry and Learning
Co-supported Normal Estimation"), Python bindings of the C++ core.

    import numpy as np, nhnet
    cloud = nhnet.read("scan.ply")                      # nhnet.Cloud: points, normals, extras
    normals = nhnet.estimate_normals(cloud.points)      # (N, 3) float64, NaN rows = failed
    nhnet.write("scan-normals.ply", cloud, normals)     # keeps the file's colours etc.
    print(nhnet.metrics(normals, gt_normals))           # mean / rms degrees, pgp5, pgp10, over30

Errors are nhnet.Error subclasses carrying the core's message: InvalidOptions and
UnprocessableInput (ValueError), InputError (ValueError and OSError), OutputError (OSError),
Cancelled. Long calls release the GIL; Ctrl-C interrupts them with KeyboardInterrupt.
"""

import os as _os

# A wheel (`pip install .`, pyproject.toml) ships the NH-Net models inside the package
# (nhnet/models/nhnet.pt, the default, and nhnet-v6.pt), where the core's default_model_path()
# does not look: it takes $NHNET_MODEL first, so the package's default model is put there when
# the caller has not set one. Every call without model= then uses it (method=None picks nhnet as
# nhnet-cli does), and so do the processes started from here (nhnet.distributed's local workers,
# which also import nhnet). An installed tree (`cmake --install`) or the build tree has no
# nhnet/models/: the core's own paths apply.
_PACKAGE_MODEL = _os.path.join(_os.path.dirname(_os.path.abspath(__file__)), "models", "nhnet.pt")
if not _os.environ.get("NHNET_MODEL") and _os.path.isfile(_PACKAGE_MODEL):
    _os.environ["NHNET_MODEL"] = _PACKAGE_MODEL

from ._nhnet import *  # noqa: E402,F401,F403  (the compiled core bindings)
from ._nhnet import __version__  # noqa: E402,F401  (project VERSION of the top CMakeLists.txt)
