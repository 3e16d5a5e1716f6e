"""Checks of tests/pip/run.sh, run by a venv's python with the installed wheel:

    check.py package NUMPY_MAJOR        import nhnet, nhnet.distributed from the venv, the wheel's
                                        version, its models, numpy's major version
    check.py estimate IN OUT            nhnet.estimate(method="nhnet", orient=None) of IN written
                                        to OUT by nhnet.write (as nhnet-cli writes it); the
                                        default method (None) gives the same normals, MFPS others
    check.py close REF GOT              GOT's normals (a text file x y z nx ny nz) within 0.5 deg
                                        of REF's for 99.9 % of the points, same points
"""

import os
import sys

import numpy as np


def package(numpy_major):
    import importlib.metadata

    import nhnet
    import nhnet.distributed  # noqa: F401  (Dask is imported only when a job runs)

    pkg = os.path.dirname(os.path.abspath(nhnet.__file__))
    assert pkg.startswith(os.path.abspath(sys.prefix) + os.sep), f"nhnet from {pkg}, not the venv"
    assert nhnet.__version__ == importlib.metadata.version("nhnet"), nhnet.__version__
    assert np.__version__.split(".")[0] == numpy_major, np.__version__
    for name in ("nhnet.pt", "nhnet-v6.pt"):
        assert os.path.isfile(os.path.join(pkg, "models", name)), f"no models/{name} in {pkg}"
    # run.sh unsets NHNET_MODEL: `import nhnet` hands the package's own model to the core.
    model = os.environ.get("NHNET_MODEL")
    assert model == os.path.join(pkg, "models", "nhnet.pt"), model
    print(f"nhnet {nhnet.__version__} in {pkg}, numpy {np.__version__}, model {model}")


def estimate(inp, out):
    import nhnet

    cloud = nhnet.read(inp)
    r = nhnet.estimate(cloud.points, method="nhnet", orient=None)
    assert r.failed == 0, r
    nhnet.write(out, cloud, r.normals)
    default = nhnet.estimate(cloud.points, orient=None)  # the core's default_method(): nhnet
    assert np.array_equal(default.normals, r.normals), "method=None did not run NH-Net"
    mfps = nhnet.estimate(cloud.points, method="mfps", orient=None)
    assert not np.array_equal(mfps.normals, r.normals), "NH-Net gave MFPS's normals"
    print(f"{len(cloud)} points, noise ratio {r.noise_ratio:.2f}, k={r.k_used}")


def close(ref, got):
    a, b = np.loadtxt(ref), np.loadtxt(got)
    assert a.shape == b.shape and a.shape[1] == 6, (a.shape, b.shape)
    np.testing.assert_allclose(b[:, :3], a[:, :3], atol=1e-8)
    ok = np.isfinite(a[:, 3:]).all(axis=1) & np.isfinite(b[:, 3:]).all(axis=1)
    dot = np.abs((a[ok, 3:] * b[ok, 3:]).sum(axis=1))
    deg = np.degrees(np.arccos(np.clip(dot, 0, 1)))
    share = (deg < 0.5).mean()
    print(f"{ok.sum()} of {len(a)} valid in both, {share:.2%} within 0.5 deg, max {deg.max():.3g} deg")
    assert ok.sum() == len(a) and share >= 0.999


if __name__ == "__main__":
    {"package": package, "estimate": estimate, "close": close}[sys.argv[1]](*sys.argv[2:])
