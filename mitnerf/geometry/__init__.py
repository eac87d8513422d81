"""Geometry of a learned field: isosurface meshes and how far they are from the truth.

* :mod:`.mesh`: sample a density on a grid over the cube ``[-b, b]^3`` and extract the
  ``density == level`` surface with marching cubes (``extract_mesh``), save it as PLY.
* :mod:`.chamfer`: the Chamfer distance between two triangle meshes (area-weighted
  surface samples, nearest neighbours with a k-d tree).
"""

from .chamfer import ChamferResult, chamfer_distance, sample_surface
from .mesh import (LEVEL, Mesh, auto_level, density_volume, extract_mesh, level_for_opacity, mesh_from_grid,
                   mesh_from_ply)

__all__ = ["LEVEL", "ChamferResult", "Mesh", "auto_level", "chamfer_distance", "density_volume", "extract_mesh",
           "level_for_opacity", "mesh_from_grid", "mesh_from_ply", "sample_surface"]
