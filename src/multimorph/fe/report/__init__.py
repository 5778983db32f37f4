"""FE reports: the files of a finished run (JSON summary, CSV, VTU series for ParaView),
its plots, its solid (STEP/STL), its report.html and its console summary.

Everything here reads finished results (:mod:`multimorph.fe.analyses`); nothing computes.
"""

from multimorph.fe.report._cad import (
    export_box_pieces,
    export_box_solid,
    export_cell_solid,
    write_surface_stl,
)
from multimorph.fe.report._comparison import (
    ComparisonCurve,
    comparison_curves,
    plot_comparison,
)
from multimorph.fe.report._files import (
    summary,
    write_comparison_figure,
    write_device_csv,
    write_device_outputs,
    write_device_solid,
    write_device_vtu,
    write_fe_outputs,
    write_hex_series,
    write_outcome,
    write_path_csv,
    write_twist_csv,
    write_twist_outputs,
    write_twist_vtu,
    write_vtu_series,
)
from multimorph.fe.report._html import fe_curves, write_report_html
from multimorph.fe.report._plots import (
    plot_curves,
    plot_device,
    plot_hex_snapshots,
    plot_path_panels,
    plot_snapshots,
    plot_twist,
)
from multimorph.fe.report._text import describe

__all__ = [
    "ComparisonCurve",
    "comparison_curves",
    "describe",
    "export_box_pieces",
    "export_box_solid",
    "export_cell_solid",
    "fe_curves",
    "plot_comparison",
    "plot_curves",
    "plot_device",
    "plot_hex_snapshots",
    "plot_path_panels",
    "plot_snapshots",
    "plot_twist",
    "summary",
    "write_comparison_figure",
    "write_device_csv",
    "write_device_outputs",
    "write_device_solid",
    "write_device_vtu",
    "write_fe_outputs",
    "write_hex_series",
    "write_outcome",
    "write_path_csv",
    "write_report_html",
    "write_surface_stl",
    "write_twist_csv",
    "write_twist_outputs",
    "write_twist_vtu",
    "write_vtu_series",
]
