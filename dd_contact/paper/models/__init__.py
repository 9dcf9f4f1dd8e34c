"""The paper's two examples as finite element models (method.md 7).

* :func:`parallelepiped`: the rectangular parallelepiped (7.1) at any resolution, clamped and
  shaken against a rigid wall; :func:`bar_scene` its decomposition with any loads.
* :func:`pin_joint`: the multi-pin lap joint (7.2), two steel plates on five rigid pins,
  hexahedral gmsh meshes (:func:`pin_joint_meshes`); :func:`pin_joint_one_mesh` its plates
  as one mesh cut by ``decompose``.

``docs/models.md`` states their dimensions, loads and meshes.
"""

from dd_contact.paper.models.common import FACE_TAGS, STEEL, block_tags
from dd_contact.paper.models.parallelepiped import (
    BAR_SCALES,
    BAR_SIZE,
    LAYOUTS,
    bar_elements,
    bar_scene,
    parallelepiped,
)
from dd_contact.paper.models.pin_joint import (
    PIN_JOINT_SCALES,
    PinJointMeshes,
    pin_joint,
    pin_joint_layout,
    pin_joint_meshes,
    pin_joint_one_mesh,
)

__all__ = [
    "BAR_SCALES",
    "BAR_SIZE",
    "FACE_TAGS",
    "LAYOUTS",
    "PIN_JOINT_SCALES",
    "STEEL",
    "PinJointMeshes",
    "bar_elements",
    "bar_scene",
    "block_tags",
    "parallelepiped",
    "pin_joint",
    "pin_joint_layout",
    "pin_joint_meshes",
    "pin_joint_one_mesh",
]
