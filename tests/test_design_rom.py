"""The designer on the real reduced model (issue 3's ``multimorph.rom``), end to end.

Slow: the vmapped path tracer compiles once per process (minutes on a loaded 2-core
machine); the search itself is small. Skipped while the ROM has no batched entry point.
"""

import tomllib
from pathlib import Path

import pytest

from multimorph.design import ROM_BATCH_NAMES, DesignSettings, design, target_from_spec
from multimorph.design._report import device_toml
from multimorph.device import device_from_spec, simulate_device
from multimorph.response import Response

rom = pytest.importorskip("multimorph.rom")
if not any(callable(getattr(rom, n, None)) for n in ROM_BATCH_NAMES):
    pytest.skip("multimorph.rom has no batched entry point yet", allow_module_level=True)

EXAMPLES = Path(__file__).parents[1] / "examples"


@pytest.mark.slow
def test_small_rom_design_is_met_or_explained():
    t = target_from_spec(tomllib.loads((EXAMPLES / "target_gripper.toml").read_text()))
    # one module per stage keeps this end-to-end check small (grading: test_design_graded)
    r = design(t, settings=DesignSettings(budget=160, population=8, seed=0, top=2,
                                          graded=False))
    assert r.evaluations <= 160 + 16
    if not r.feasible:
        assert r.explanation                           # never a silent poor design
    best = r.best
    if best is None:
        return
    assert all(isinstance(x, Response) for x in best.responses)
    dev = device_from_spec(tomllib.loads(device_toml(best.device)))
    res = simulate_device(dev)                         # the device file simulates
    for sr in best.stages:
        _, ph = res.sequence.windows[sr.name]
        if sr.end is not None:
            assert ph == pytest.approx(sr.end, rel=1e-2)   # the file rounds to 0.01 mm
