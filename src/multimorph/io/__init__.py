"""Input/output at the edges: atomic output folders, JSON, TOML specs with units."""

from multimorph.io._output import atomic_output_dir, to_jsonable, write_json
from multimorph.io._toml import load_toml

__all__ = ["atomic_output_dir", "load_toml", "to_jsonable", "write_json"]
