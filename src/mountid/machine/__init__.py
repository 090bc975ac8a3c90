"""The user's view of a generated module: checked inputs, the two directions (frequencies and
identification), matrices, the first-order form and sensor rows, calling generated functions by name.

Depends on the runtime and the generated modules only (numpy, scipy); the engine is imported lazily, and only to
generate a description file that is not cached yet.
"""

from mountid.machine.dynamics import (
    call,
    damped_modes,
    damped_pole_derivatives,
    damped_poles,
    matrices,
    pair_with_undamped,
    pole_damping_ratios,
    ratio_derivatives,
    read_only,
    recently_used,
    rigid_motion,
    sensor_row,
    state_matrix,
    undamped_modes,
    unit_vector,
)
from mountid.machine.model import Machine, Solution
from mountid.machine.modules import (
    GeneratedModule,
    cache_folder,
    description_file,
    module_from_description,
    shipped_machines,
)

__all__ = [
    "GeneratedModule",
    "Machine",
    "Solution",
    "cache_folder",
    "call",
    "damped_modes",
    "damped_pole_derivatives",
    "damped_poles",
    "description_file",
    "matrices",
    "module_from_description",
    "pair_with_undamped",
    "pole_damping_ratios",
    "ratio_derivatives",
    "read_only",
    "recently_used",
    "rigid_motion",
    "sensor_row",
    "shipped_machines",
    "state_matrix",
    "undamped_modes",
    "unit_vector",
]
