"""The studies: numerics (stable steps, orders; its CSV and charts in numerics_report), the
chooser, calibration, the flow study (plan and run in study, the analysis in study_analysis,
the chart and table in study_report) and its grid-convergence index. May import every room
below them."""
