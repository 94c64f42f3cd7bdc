"""The clinic gateway: the Litestar HTTP API, the services behind it and the analysis queue."""
