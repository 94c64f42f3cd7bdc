"""Services: the gateway's behaviour, independent of HTTP. Controllers stay thin over these."""
