"""The URDF fixture packages of tests/fixtures/urdf, with meshes generated here.

``tests/fixtures/urdf`` holds robot descriptions written for these tests in the layouts
ROS packages use (``urdf_tour``: a tutorial package with ``urdf/`` and ``meshes/``;
``arm_description``: an ament_python ``<robot>_description`` package that colcon
installs). Their meshes are not committed: :func:`package` copies a package and writes
its meshes with trimesh (STL) and pycollada (COLLADA, whose material names a texture
that is not shipped, as the ROS tutorial's finger meshes name a missing normal map).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import collada
import numpy as np
import trimesh
from collada import geometry, material, source
from collada import scene as dae_scene

FIXTURES = Path(__file__).parent / "fixtures" / "urdf"

#: A finger: a long thin box, its base at the origin, pointing along +x (metres).
FINGER = trimesh.creation.box(
    extents=(0.1, 0.02, 0.02), transform=trimesh.transformations.translation_matrix((0.05, 0, 0))
)
#: A finger tip: a short wedge-like box.
FINGER_TIP = trimesh.creation.box(
    extents=(0.04, 0.015, 0.015), transform=trimesh.transformations.translation_matrix((0.02, 0, 0))
)
#: The arm's links (STL, millimetres as many description packages ship them).
ARM_BASE = trimesh.creation.cylinder(radius=60.0, height=40.0, sections=16)
ARM_LINK = trimesh.creation.box(
    extents=(300.0, 40.0, 40.0), transform=trimesh.transformations.translation_matrix((150.0, 0, 0))
)
#: Meshes each package's files name, by path inside the package.
MESHES = {
    "urdf_tour": {"meshes/finger.dae": FINGER, "meshes/tips/finger_tip.dae": FINGER_TIP},
    "arm_description": {"meshes/base.stl": ARM_BASE, "meshes/link.stl": ARM_LINK},
}
#: The texture the COLLADA files name and nobody ships.
MISSING_TEXTURE = "finger_color.png"


def write_dae(path: Path, mesh: trimesh.Trimesh, texture: str = MISSING_TEXTURE) -> None:
    """A COLLADA file of ``mesh`` whose material's colour and glow are the image
    ``texture`` (a file name only: the image itself is not written)."""
    doc = collada.Collada()
    image = material.CImage("finger-image", texture)
    surface = material.Surface("finger-surface", image)
    sampler = material.Sampler2D("finger-sampler", surface)
    effect = material.Effect(
        "finger-effect",
        [surface, sampler],
        "phong",
        diffuse=material.Map(sampler, "UVSET0"),
        emission=material.Map(sampler, "UVSET0"),
    )
    skin = material.Material("finger-material", "finger", effect)
    doc.images.append(image)
    doc.effects.append(effect)
    doc.materials.append(skin)
    vertices = source.FloatSource("vertices", np.asarray(mesh.vertices).ravel(), ("X", "Y", "Z"))
    shape = geometry.Geometry(doc, "shape", "finger", [vertices])
    inputs = source.InputList()
    inputs.addInput(0, "VERTEX", "#vertices")
    shape.primitives.append(shape.createTriangleSet(np.asarray(mesh.faces).ravel(), inputs, "skin"))
    doc.geometries.append(shape)
    node = dae_scene.Node(
        "finger",
        children=[dae_scene.GeometryNode(shape, [dae_scene.MaterialNode("skin", skin, [])])],
    )
    doc.scenes.append(dae_scene.Scene("scene", [node]))
    doc.scene = doc.scenes[0]
    path.parent.mkdir(parents=True, exist_ok=True)
    doc.write(str(path))


def write_meshes(folder: Path, name: str) -> None:
    """Write package ``name``'s meshes into its folder ``folder``."""
    for relative, mesh in MESHES[name].items():
        path = folder / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        if path.suffix == ".dae":
            write_dae(path, mesh)
        else:
            mesh.export(path)


def package(name: str, into: Path, folder_name: str | None = None) -> Path:
    """A copy of fixture package ``name`` in ``into`` (its folder called ``folder_name``,
    by default the package's name), with its meshes written."""
    folder = into / (folder_name or name)
    shutil.copytree(FIXTURES / name, folder)
    write_meshes(folder, name)
    return folder


def draw(paths: list[str]) -> None:
    """Load each URDF and build its MeshCat scene, as a notebook cell would."""
    from rosbook.robots import urdf
    from rosbook.viz import scene

    for path in paths:
        scene.show(urdf.load(path))


if __name__ == "__main__":  # python tests/urdf_fixtures.py draw|read PATH...: a fresh process
    import sys

    if sys.argv[1] == "draw":
        draw(sys.argv[2:])
    else:  # read: the meshes with trimesh alone, as without rosbook
        for path in sys.argv[2:]:
            trimesh.load(path, force="mesh")
