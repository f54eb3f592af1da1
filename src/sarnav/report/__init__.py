"""sarnav.report: figures (matplotlib, Agg canvas, PNG).

- ``figures``: campaign figures (errors against ±3σ per block, residuals)
- ``study_figure``: the study comparison of 3σ bounds
"""
