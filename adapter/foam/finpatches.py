"""The fins' own prism layers (``case.fin_layers``, ``case.fin_first_layer_m``; docs/case.md).

snappyHexMesh sets prism layers per patch and makes one patch per solid of a multi-solid STL.
When the flippers and the flukes get layers of their own, the case meshes ``whale_regions.stl``
(the whale's triangles as the solids body, flippers, flukes), so that snappyHexMesh makes the
patches :data:`PATCHES` and gives each its layer values; :func:`merge_whale_patches` then merges
them back into the one ``whale`` patch that the run, its loads and the step-server know, with
OpenFOAM's ``createPatch``. The layer fields snappyHexMesh wrote on the three patches
(``nSurfaceLayers``, ``thickness``, ``thicknessFraction`` in ``0/``) are written onto the merged
patch, so that the coverage of the layers is read as on a whale meshed as one patch.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from adapter.body.regions import REGIONS
from adapter.errors import FoamFileError
from adapter.foam.foamascii import patch_face_areas, read_boundary, read_patch_field
from adapter.foam.tools import run_utility

#: the whale's patches as snappyHexMesh names them from the solids of whale_regions.stl
PATCHES = tuple(f"whale_{region}" for region in REGIONS)
#: the fields snappyHexMesh's layer stage writes (``writeFlags (layerFields)``)
LAYER_FIELDS = ("nSurfaceLayers", "thickness", "thicknessFraction")

_CREATE_PATCH_DICT = """\
FoamFile
{{
    version     2.0;
    format      ascii;
    class       dictionary;
    object      createPatchDict;
}}

// the whale's patches of snappyHexMesh (one a region, for the fins' own layers) as one patch
pointSync false;

patches
(
    {{
        name            whale;
        patchInfo       {{ type wall; }}
        constructFrom   patches;
        patches         ({parts});
    }}
);
"""


def whale_parts(case) -> tuple:
    """The whale's region patches (:data:`PATCHES`) in the case's mesh, in its order; empty
    when the whale is one patch."""
    boundary = read_boundary(Path(case) / "constant" / "polyMesh" / "boundary")
    return tuple(name for name in boundary if name in PATCHES)


def merge_whale_patches(case, parts: tuple) -> None:
    """createPatch -overwrite: the patches ``parts`` become the one patch ``whale``; the layer
    fields in ``0/`` follow them (or are removed when the merged patch's faces are not the
    parts' in their order, as the faces' areas tell)."""
    case = Path(case)
    areas = [patch_face_areas(case, p) for p in parts]
    zero = case / "0"
    fields = {}
    for name in LAYER_FIELDS:
        if (zero / name).is_file():
            fields[name] = np.concatenate([read_patch_field(zero / name, p, len(a))
                                           for p, a in zip(parts, areas, strict=True)])
    (case / "system" / "createPatchDict").write_text(
        _CREATE_PATCH_DICT.format(parts=" ".join(parts)))
    run_utility(case, ["createPatch", "-overwrite"])
    merged = patch_face_areas(case, "whale")
    joined = np.concatenate(areas)
    in_order = merged.shape == joined.shape and np.allclose(merged, joined, rtol=1e-9)
    for name, values in fields.items():
        path = zero / name
        if in_order:
            path.write_text(merged_field_text(path.read_text(), parts, values))
        else:
            path.unlink()


def merged_field_text(text: str, parts: tuple, values: np.ndarray) -> str:
    """A field file's text with the boundary entries of ``parts`` replaced by one ``whale``
    entry holding ``values`` (a scalar per face, ``calculated``)."""
    entry = ("    whale\n    {\n        type            calculated;\n"
             f"        value           nonuniform List<scalar> {len(values)}\n(\n"
             + "".join(f"{v:.10g}\n" for v in values) + ")\n;\n    }\n")
    spans = []
    for part in parts:
        m = re.search(rf"^[ \t]*{re.escape(part)}\s*\{{[^}}]*\}}[ \t]*\n", text, re.M)
        if m is None:
            raise FoamFileError(f"no boundary entry {part} in the field")
        spans.append(m.span())
    spans.sort()
    out, last = [], 0
    for i, (start, end) in enumerate(spans):
        out.append(text[last:start])
        if i == 0:
            out.append(entry)
        last = end
    return "".join(out) + text[last:]
