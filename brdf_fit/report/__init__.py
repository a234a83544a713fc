"""Reports: the HTML pages (``pages``), their three.js viewer (``web_viewer``)
and the matplotlib figures (``plots``, ``plot_base``)."""
