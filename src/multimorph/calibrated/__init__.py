"""Calibrated cell model: the reduced (Ritz) model corrected against the project's own FE.

See ``docs/validation.md``. The FE reference data set (``fe_reference.npz``) is described
in :mod:`multimorph.calibrated._dataset` and rebuilt by
``python -m multimorph.calibrated.build_dataset``.
"""

from multimorph.calibrated._dataset import (
    CURVES,
    HOLDOUT_FRACTION,
    REFERENCE_SETS,
    SPLIT_SEED,
    ReferenceSet,
    is_holdout,
    load_reference,
    reference_spec,
)
from multimorph.calibrated._model import CalibratedModel, CalibrationWarning, load_model

__all__ = ["CURVES", "HOLDOUT_FRACTION", "REFERENCE_SETS", "SPLIT_SEED", "CalibratedModel",
           "CalibrationWarning", "ReferenceSet", "is_holdout", "load_model", "load_reference",
           "reference_spec"]
