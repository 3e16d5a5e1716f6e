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

from ._nhnet import *  # noqa: F401,F403  (the compiled core bindings)
from ._nhnet import __version__  # noqa: F401  (project VERSION of the top CMakeLists.txt)
