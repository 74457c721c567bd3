"""The whale's surface type: a closed surface mesh with the paper's landmarks and regions."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from adapter.body.leadingedge import leading_edge_mask
from adapter.body.meshfile import write_region_stl, write_surface
from adapter.body.polygons import triangulate, unique_edges
from adapter.body.regions import BODY, FLIPPERS, FLUKES, REGIONS, flipper_triangles
from adapter.errors import GeometryError


@dataclass
class WhaleSurface:
    """A closed surface mesh with the paper's landmarks.

    Attributes
    ----------
    points : (N, 3) float64, rest positions (m).
    faces : list of (F_k, n_k) int arrays, polygons grouped by corner count (3 or 4), outward.
    landmarks : name -> node index, for every name in :data:`LANDMARKS`.
    length : body length L (m), rostrum to tail end along x.
    origin : position of the rostrum's axis point; s = (x - origin[0]) / length.
    face_regions : None, or a list parallel to ``faces``: the region index (:data:`REGIONS`)
        each face was built as (the procedural whale: its flipper and fluke fins); None for a
        mesh file (:meth:`triangle_regions` then finds the flippers geometrically).
    """

    points: np.ndarray
    faces: list
    landmarks: dict
    length: float
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    face_regions: list | None = None

    @property
    def n_nodes(self) -> int:
        return len(self.points)

    @property
    def edges(self) -> np.ndarray:
        """(E, 2) int64, every undirected edge once, smaller index first."""
        return unique_edges(self.faces)

    @property
    def triangles(self) -> np.ndarray:
        """(T, 3) int64: triangles, with each quad split along its shorter diagonal."""
        return triangulate(self.points, self.faces)

    @property
    def s(self) -> np.ndarray:
        """(N,) position of every node along the body, fraction of L from the rostrum."""
        return (self.points[:, 0] - self.origin[0]) / self.length

    def volume(self, points: np.ndarray | None = None) -> float:
        """Enclosed volume (m^3) of the surface with the given node positions."""
        p = self.points if points is None else points
        t = self.triangles
        a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    @property
    def is_whale(self) -> bool:
        """Whether the surface has the whale's landmarks (a rigid body needs none)."""
        return "tail_base" in self.landmarks

    def triangle_regions(self) -> np.ndarray:
        """(T,) int region index (:data:`REGIONS`) of every triangle of :attr:`triangles`.

        Flukes: triangles whose centroid lies behind the tail base (s > s of the landmark
        ``tail_base``, the animator's fluke gate). Flippers (of the rest): the faces built as
        flippers when :attr:`face_regions` is known (the procedural whale), else the geometric
        rule of :func:`flipper_triangles`. Body: everything else, and the whole of a body
        without the whale's landmarks (a rigid body: :attr:`is_whale` False).
        """
        tri = self.triangles
        if not self.is_whale:
            return np.full(len(tri), BODY, dtype=np.int64)
        centroid = self.points[tri].mean(axis=1)
        s_c = (centroid[:, 0] - self.origin[0]) / self.length
        if self.face_regions is not None:
            per_tri = [r if f.shape[1] == 3 else np.concatenate([r, r])
                       for f, r in zip(self.faces, self.face_regions, strict=True)]
            flippers = np.concatenate(per_tri) == FLIPPERS
        else:
            flippers = flipper_triangles(self.points, tri, self.landmarks, self.origin,
                                         self.length)
        out = np.full(len(tri), BODY, dtype=np.int64)
        out[flippers] = FLIPPERS
        out[s_c > float(self.s[self.landmarks["tail_base"]])] = FLUKES
        return out

    def region_areas(self) -> dict:
        """Area (m2) of every region of :meth:`triangle_regions`."""
        p, tri = self.points, self.triangles
        area = 0.5 * np.linalg.norm(np.cross(p[tri[:, 1]] - p[tri[:, 0]],
                                             p[tri[:, 2]] - p[tri[:, 0]]), axis=1)
        reg = self.triangle_regions()
        return {name: float(area[reg == k].sum()) for k, name in enumerate(REGIONS)}

    def write_regions_stl(self, path: str | Path, only: str | None = None) -> None:
        """An ASCII STL with one solid per region, named as :data:`REGIONS` (the whaleLoads
        function object's ``regions`` surface; docs/openfoam-plugin.md); ``only``: that
        region's solid alone."""
        regions = self.triangle_regions()
        if only is None:
            write_region_stl(path, self.points, self.triangles, regions)
            return
        if only not in REGIONS:
            raise ValueError(f"no region {only!r}: the regions are {', '.join(REGIONS)}")
        mine = np.where(regions == REGIONS.index(only), 0, -1)
        write_region_stl(path, self.points, self.triangles, mine, names=(only,))

    def fluke_blade(self, clearance_m: float) -> np.ndarray:
        """Which triangles are the flukes' blade: the flukes' triangles
        (:meth:`triangle_regions`) whose centroid lies more than ``clearance_m`` (m, along the
        body) behind the tail base, so that the hinge is left out."""
        centroid_x = self.points[self.triangles].mean(axis=1)[:, 0]
        s_c = (centroid_x - self.origin[0]) / self.length
        behind = s_c > float(self.s[self.landmarks["tail_base"]]) + clearance_m / self.length
        blade = (self.triangle_regions() == FLUKES) & behind
        if not blade.any():
            raise GeometryError(f"no fluke triangle lies {clearance_m:.4g} m behind the tail "
                                "base: give a smaller case.fluke_clearance, or "
                                "case.fluke_level = case.fluke_edge_level = 0 for no finer "
                                "cells at the flukes")
        return blade

    def write_fluke_blade_stl(self, path: str | Path, clearance_m: float) -> None:
        """An ASCII STL of the flukes' blade (:meth:`fluke_blade`; one solid ``flukeBlade``)."""
        write_region_stl(path, self.points, self.triangles,
                         np.where(self.fluke_blade(clearance_m), 0, -1), names=("flukeBlade",))

    def write_leading_edge_stl(self, path: str | Path, fin: np.ndarray, name: str,
                               strip_m: float) -> None:
        """An ASCII STL (one solid ``name``) of the forward tenth of the chord of the fin whose
        triangles ``fin`` marks (:func:`~adapter.body.leadingedge.leading_edge_mask`, sections
        ``strip_m`` wide about the body's axis)."""
        centroids = self.points[self.triangles].mean(axis=1)
        edge = np.zeros(len(centroids), dtype=bool)
        edge[fin] = leading_edge_mask(centroids[fin], float(self.origin[1]), strip_m)
        write_region_stl(path, self.points, self.triangles, np.where(edge, 0, -1),
                         names=(name,))

    def write(self, path: str | Path, point_data: dict | None = None) -> None:
        """Write the surface; the format follows the suffix (STL, OBJ, VTK, VTU, VTP, PLY ...).

        STL gets triangles (what snappyHexMesh reads); the other formats keep the quads.
        """
        write_surface(path, self.points, self.faces, point_data=point_data)
