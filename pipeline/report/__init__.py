"""Reports: results.json, Markdown and HTML with plots, JUnit XML, history plots."""
