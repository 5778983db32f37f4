"""Device room: modules on one pressure line, rod kinematics, sequence analysis."""

from multimorph.device._device import Device, device_from_spec
from multimorph.device._kinematics import RodStrains, centerline, chain, segment_transform
from multimorph.device._modules import MODULE_KINDS, Module, ModuleStrains, module_strains
from multimorph.device._sequence import ModuleCurve, SequenceReport, analyse_sequence
from multimorph.device._simulate import DeviceResult, default_cell_model, simulate_device

__all__ = [
    "MODULE_KINDS",
    "Device",
    "DeviceResult",
    "Module",
    "ModuleCurve",
    "ModuleStrains",
    "RodStrains",
    "SequenceReport",
    "analyse_sequence",
    "centerline",
    "chain",
    "default_cell_model",
    "device_from_spec",
    "module_strains",
    "segment_transform",
    "simulate_device",
]
