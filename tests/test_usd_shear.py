"""A sheared placement (a corner part adapted to a corner a little off its own angle)
keeps its geometry in USD with no shear in any matrix: the shear is baked into the
instance's prototype (one per part or cut and shear, in the layer's cuts file), and
the instance's matrix holds rotation, scale and translation only. Blender's USD
importer decomposes a matrix into those three and dropped the shear: in the demo
district 193 corner instances moved by up to 4.8 cm in Blender alone
(tests/test_blender.py imports the same layer, conftest's ``sheared_layer``, into
Blender itself)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
from pxr import Usd, UsdGeom

from citysynth.export.assemble import place
from citysynth.export.layout import Layout
from citysynth.export.prototypes import prototype_pieces
from citysynth.export.shear import baked_prototype, sheared
from citysynth.export.usd import CUTS_PRIM, USER, part_file, validate

ROOT = Path(__file__).resolve().parent.parent
LIB = ROOT / "examples" / "library"
BLOCK = ROOT / "examples" / "blocks" / "block.geojson"
SHEARS = (0.05, -0.03, 0.05, 0.0)   # by instance index mod 4: two shears, shared, and none


def sheared_layout(lay: Layout) -> Layout:
    """``lay`` with its instances' Y axes sheared along X by :data:`SHEARS`."""
    out = []
    for n, inst in enumerate(lay.instances):
        h = SHEARS[n % len(SHEARS)]
        (xx, xy), (yx, yy) = inst.x_axis, inst.y_axis
        out.append(replace(inst, y_axis=(yx + h * xx, yy + h * xy)))
    return replace(lay, instances=out)


def _instance_meshes(stage: Usd.Stage) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Each instance's meshes as composed: (part, local matrix, world points)."""
    cache = UsdGeom.XformCache()
    out = []
    for prim in stage.Traverse():
        if not prim.IsInstance():
            continue
        m = np.asarray(UsdGeom.Xformable(prim).GetLocalTransformation())
        pts = []
        for mesh in Usd.PrimRange(prim, Usd.TraverseInstanceProxies()):
            if mesh.IsA(UsdGeom.Mesh):
                p = np.asarray(UsdGeom.Mesh(mesh).GetPointsAttr().Get(), dtype=float)
                w = np.asarray(cache.GetLocalToWorldTransform(mesh))
                pts.append((np.c_[p, np.ones(len(p))] @ w)[:, :3])
        out.append((prim.GetAttribute(USER + "part").Get(), m,
                    np.vstack(pts) if pts else np.zeros((0, 3))))
    return out


def test_no_instance_matrix_shears_and_the_geometry_is_where_the_layout_puts_it(
        sheared_layer, sample_db):
    path, lay = sheared_layer
    stage = Usd.Stage.Open(str(path))
    got = _instance_meshes(stage)
    assert [part for part, _m, _p in got] == [i.part for i in lay.instances]
    for (_part, m, pts), inst in zip(got, lay.instances, strict=True):
        x, y = m[0, :3], m[1, :3]
        assert abs(x @ y) <= 1e-4 * np.linalg.norm(x) * np.linalg.norm(y)
        want = np.vstack([place(p, inst)[0] for p in prototype_pieces(sample_db, inst)])
        assert pts.shape == want.shape
        np.testing.assert_allclose(pts, want, atol=1e-4)   # float32 points
    assert validate(path) == []


def test_a_sheared_prototype_is_made_once_per_shear_in_the_layers_own_file(
        sheared_layer):
    path, lay = sheared_layer
    stage = Usd.Stage.Open(str(path))
    want = {baked_prototype(i) for i in lay.instances}
    assert len(stage.GetPrototypes()) == len(want)
    cuts = Usd.Stage.Open(str(path.with_name("block.cuts.usdc")))
    baked = {p.GetName(): p.GetCustomDataByKey("citysynth:shear")
             for p in cuts.GetPrimAtPath(f"/{CUTS_PRIM}").GetChildren()}
    shears = {round(i.shear, 9) for i in lay.instances if sheared(i)}
    assert {round(h, 4) for h in shears} == {0.05, -0.03}   # and the layout's own rounding
    assert {round(h, 9) for h in baked.values() if h is not None} == shears
    assert sum(h is not None for h in baked.values()) == \
        len({baked_prototype(i) for i in lay.instances if sheared(i)})
    # the library parts placed unsheared still reference the shared part files
    plain = {i.part for i in lay.instances if i.cut is None and not sheared(i)}
    assert plain and all((path.parent / part_file(p)).is_file() for p in plain)
