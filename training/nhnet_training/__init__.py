"""nhnet training package: benchmark / training data generation (and, later, training).

Modules:
    meshes   -- CGAL demo meshes (extracted from Debian's libcgal-demo) and OFF/PLY readers
    datagen  -- deterministic point-cloud sampling with ground-truth normals (``nhnet-datagen``)
"""

__version__ = "0.1.0"
