"""sarnav.report: figures (matplotlib, Agg canvas, PNG), file writers and the pages made to read and share results.

- ``figures``: campaign figures (errors against ±3σ per block, residuals scaled to the bulk of the data)
- ``rda_nav_figures``, ``study_figure``, ``sensitivity``, ``image_files``: the kinds' figures and files
- ``outputs``: what an output folder holds (campaign, study, bpa-sensitivity, image) and reading a campaign
- ``html`` (``sarnav report``; with ``campaign_page``, ``output_pages``, ``html_parts``): ``report.html``
- ``compare`` (``sarnav compare``; with ``overlays``): ``compare.html`` and ``compare.csv``
- ``redraw`` (``sarnav figures``): a campaign's or study's figures drawn again from results.nc
"""
