"""Input/output at the edges: output folders checked and claimed, written atomically; JSON;
TOML specs with units."""

from multimorph.io._claim import OutputBusyError, check_output_dir, claim_output
from multimorph.io._output import atomic_output_dir, to_jsonable, write_json
from multimorph.io._toml import load_toml

__all__ = ["OutputBusyError", "atomic_output_dir", "check_output_dir", "claim_output",
           "load_toml", "to_jsonable", "write_json"]
