"""Server-rendered browser pages (Jinja2 + htmx) of the gateway."""
