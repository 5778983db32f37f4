"""Device room: modules on one pressure line, rod kinematics, sequence analysis."""

from multimorph.device._device import Device, device_from_spec
from multimorph.device._kinematics import (
    RodStrains,
    centerline,
    chain,
    frames_along,
    segment_transform,
)
from multimorph.device._modules import (
    MODULE_KINDS,
    Module,
    ModuleStrains,
    module_strains,
    path_strains,
)
from multimorph.device._sequence import ModuleCurve, SequenceReport, analyse_sequence
from multimorph.device._shape import Body, DeviceShape, Hub, device_shape
from multimorph.device._simulate import (
    DeviceResult,
    answered_cell,
    default_cell_model,
    simulate_device,
)

__all__ = [
    "MODULE_KINDS",
    "Body",
    "Device",
    "DeviceResult",
    "DeviceShape",
    "Hub",
    "Module",
    "ModuleCurve",
    "ModuleStrains",
    "RodStrains",
    "SequenceReport",
    "analyse_sequence",
    "answered_cell",
    "centerline",
    "chain",
    "default_cell_model",
    "device_from_spec",
    "device_shape",
    "frames_along",
    "module_strains",
    "path_strains",
    "segment_transform",
    "simulate_device",
]
