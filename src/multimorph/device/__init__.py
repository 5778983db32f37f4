"""Device room: modules on one pressure line, rod kinematics, sequence analysis."""

from multimorph.device._kinematics import RodStrains, centerline, chain, segment_transform
from multimorph.device._sequence import ModuleCurve, SequenceReport, analyse_sequence

__all__ = [
    "ModuleCurve",
    "RodStrains",
    "SequenceReport",
    "analyse_sequence",
    "centerline",
    "chain",
    "segment_transform",
]
