"""Plots from results only (no model runs here): sweep design maps."""

from multimorph.viz._maps import (
    design_maps,
    families_figure,
    model_note,
    pc_contour_figure,
    pc_line_figure,
    resolve_variable,
)

__all__ = ["design_maps", "families_figure", "model_note", "pc_contour_figure",
           "pc_line_figure", "resolve_variable"]
