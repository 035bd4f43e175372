"""The assumption boxes a verdict holds over: a space file's types and ranges
(``box``), scripted worst-case approaches (``space``) and boxes around recordings of
real operators (``recorded``)."""
