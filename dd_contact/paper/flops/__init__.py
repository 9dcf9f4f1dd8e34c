"""The paper's operation-count (FLOPs) model of FULL, v-w-u, w-v-u, w-u and v-u (method.md 6-7).

The package re-exports the model's API (``__all__``); its modules, each importing only those
listed before it:

* :mod:`~dd_contact.paper.flops.model`: the kernels f1-f4, the scene sizes, the per-algorithm
  counts (Table 1) and the reports (Table 2);
* :mod:`~dd_contact.paper.flops.bandwidth`: half-bandwidths of structured meshes and sparse
  matrices;
* :mod:`~dd_contact.paper.flops.paper`: the paper's two examples, the parallelepiped and the
  multi-pin joint, as scene-size generators;
* :mod:`~dd_contact.paper.flops.scene_files`: the JSON scene format;
* :mod:`~dd_contact.paper.flops.studies`: the paper's parameter studies, their charts, and the
  text and JSON forms of the reports;
* :mod:`~dd_contact.paper.flops.bridge`: the sizes of a dolfinx :class:`~dd_contact.scene.Scene`
  (``sizes_from_scene``).

The counts are the engine's own schedule (:mod:`dd_contact.solvers.schedule`) tallied on each
algorithm's variant of the scene. Only the bridge reads dolfinx objects; matplotlib is imported
only when a chart is drawn. The model, its
derivations and the scene schema are described in ``docs/cost.md``.
"""

from dd_contact.paper.flops.bandwidth import (
    half_bandwidth_box,
    half_bandwidth_structured_hex,
    matrix_half_bandwidth,
    rcm_half_bandwidth,
)
from dd_contact.paper.flops.bridge import half_bandwidth_of, sizes_from_scene
from dd_contact.paper.flops.model import (
    ALGORITHMS,
    ContactCounts,
    CostReport,
    MeshCost,
    MeshCounts,
    SceneSizes,
    SubdomainCounts,
    applicable_algorithms,
    compare,
    f1,
    f2,
    f3,
    f4,
    operation_counts,
    schedule_counts,
)
from dd_contact.paper.flops.paper import (
    PAPER_BAR,
    PaperBar,
    PinJointLayout,
    parallelepiped_sizes,
    pin_joint_mesh_counts,
    pin_joint_sizes,
)
from dd_contact.paper.flops.scene_files import load_scene, scene_from_dict, scene_to_dict
from dd_contact.paper.flops.studies import (
    CHANGES_SWEEP,
    CONTACT_SCALES,
    STEPS_SWEEP,
    Study,
    format_table,
    parallelepiped_studies,
    pin_joint_studies,
    plot_study,
    scene_studies,
    to_json_dict,
    write_studies,
)

__all__ = [
    "ALGORITHMS",
    "CHANGES_SWEEP",
    "CONTACT_SCALES",
    "PAPER_BAR",
    "STEPS_SWEEP",
    "ContactCounts",
    "CostReport",
    "MeshCost",
    "MeshCounts",
    "PaperBar",
    "PinJointLayout",
    "SceneSizes",
    "Study",
    "SubdomainCounts",
    "applicable_algorithms",
    "compare",
    "f1",
    "f2",
    "f3",
    "f4",
    "format_table",
    "half_bandwidth_box",
    "half_bandwidth_of",
    "half_bandwidth_structured_hex",
    "load_scene",
    "matrix_half_bandwidth",
    "operation_counts",
    "parallelepiped_sizes",
    "parallelepiped_studies",
    "pin_joint_mesh_counts",
    "pin_joint_sizes",
    "pin_joint_studies",
    "plot_study",
    "rcm_half_bandwidth",
    "scene_from_dict",
    "scene_studies",
    "scene_to_dict",
    "schedule_counts",
    "sizes_from_scene",
    "to_json_dict",
    "write_studies",
]
