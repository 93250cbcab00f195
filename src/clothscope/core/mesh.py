"""Regular-grid cloth meshes: faces, vertex normals and the Mitsuba mesh, shared by the fit and the synthetic generator."""
from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np


def grid_faces(n: int) -> np.ndarray:
    """Triangles (counter-clockwise seen from +z) of an n x n vertex grid, row-major, rows along +y."""
    idx = np.arange(n * n, dtype=np.uint32).reshape(n, n)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    return np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])


def grid_normals(positions: np.ndarray) -> np.ndarray:
    """Per-vertex normals of an (n, n, 3) displaced grid from central differences."""
    du = np.gradient(positions, axis=1)
    dv = np.gradient(positions, axis=0)
    normals = np.cross(du, dv)
    return normals / np.linalg.norm(normals, axis=-1, keepdims=True)


def cloth_mesh(mi: ModuleType, positions: np.ndarray, texcoords: np.ndarray, keep_vertex: np.ndarray, bsdf: Any) -> Any:
    """Build a Mitsuba mesh from an (n, n, 3) grid; triangles touching a dropped vertex are holes."""
    n = positions.shape[0]
    faces = grid_faces(n)
    keep = keep_vertex.reshape(-1)
    faces = faces[keep[faces].all(axis=1)]
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh("cloth", n * n, len(faces), props=props, has_vertex_normals=True, has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(positions.reshape(-1).astype(np.float32))
    params["vertex_normals"] = mi.Float(grid_normals(positions).reshape(-1).astype(np.float32))
    params["vertex_texcoords"] = mi.Float(texcoords.reshape(-1).astype(np.float32))
    params["faces"] = mi.UInt32(faces.reshape(-1))
    params.update()
    return mesh
