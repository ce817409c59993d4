"""The operator's console (``retrofit console``) and the offline HTML report (``--html``).

``engine``: the steerable run on the 002 controller (the one module that drives the engine);
``views``: what the page draws, cut from a run's port frames; ``runreport``: the run's report
with the operator's actions and the measured feeds; ``server``: the state behind the page (one
run at a time, STOP in every state); ``api``: the Starlette app and its JSON API; ``guard``: the
token, Host and Origin checks and who holds control; ``schema``: the request bodies' schemas;
``programs``: the folder programs are opened from; ``report_html``: the self-contained HTML
report, ``packing`` its packed store; ``static/``: the page and its scripts.
"""
