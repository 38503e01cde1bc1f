"""The Dash pages of the UI, one module per view: each has ``layout(ctx)`` (components) and
``register(app, ctx, w)`` (the callbacks that read component values, call one plain data
function of :mod:`vectorid.views.ui` and put its result into components). Layout only: no
number is computed here."""
