"""faultlab.report.html: static, self-contained HTML reports (Jinja2 pages, Bokeh tables and plots).

:mod:`~faultlab.report.html.site` is the reusable builder (pages as data, :func:`write_site`);
:mod:`~faultlab.report.html.campaign` the report of a campaign's Analysis (``report --html``),
:mod:`~faultlab.report.html.mutation` the report of a mutation campaign, and
:mod:`~faultlab.report.html.bundle` the report of any analysis saved as tables and figures (study, effects).
"""
