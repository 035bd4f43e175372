"""Taking parameters to deployment: ``export`` (params.yaml, the certificate and the
assessor's page), ``certificate`` (what is certified, and ``check``), the assessor's
page (``assessor_report``) and the standards' terms it names
(``standard_terms``)."""
