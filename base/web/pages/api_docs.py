"""The interactive API docs at /schema without the internet: Swagger UI from the vendored copy, no inline script.

Litestar's own renderers load Swagger UI or Redoc from a CDN and start them with an inline script holding the
whole schema, which a clinic offline cannot load and a strict CSP refuses. This page links the vendored
bundle and base/web/static/js/swagger-init.js, which reads the openapi.json address from a data- attribute.
Only Swagger UI is served: Redoc, Elements and RapiDoc would need a CDN, so their paths answer 404.
"""

from __future__ import annotations

from collections.abc import Sequence
from html import escape
from typing import Any

from litestar import Request
from litestar.openapi.plugins import JsonRenderPlugin, OpenAPIRenderPlugin, YamlRenderPlugin

from base.web.pages.assets import STATIC_PATH

SWAGGER_DIR = f"{STATIC_PATH}/vendor/swagger-ui"
SWAGGER_JS = f"{SWAGGER_DIR}/swagger-ui-bundle.js"
SWAGGER_CSS = f"{SWAGGER_DIR}/swagger-ui.css"
SWAGGER_INIT_JS = f"{STATIC_PATH}/js/swagger-init.js"

_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title}</title>
<link rel="icon" href="data:,">
<link rel="stylesheet" href="{css}">
<script src="{js}" defer></script>
<script src="{init}" defer></script>
</head>
<body>
<div id="swagger-ui" data-openapi-url="{openapi_url}"></div>
</body>
</html>
"""


class OfflineSwaggerRenderPlugin(OpenAPIRenderPlugin):
    """Swagger UI from /static/vendor/swagger-ui, started by /static/js/swagger-init.js.

    Unlike litestar's SwaggerRenderPlugin it adds no OAuth2 redirect page (the API logs in with a bearer token).
    The `data:,` icon keeps the browser from asking for /favicon.ico, which would only answer "log in first".
    """

    def __init__(self, *, path: str | Sequence[str] = "/swagger", **kwargs: Any) -> None:
        super().__init__(path=path, favicon="", style="", **kwargs)

    def render(self, request: Request, openapi_schema: dict[str, Any]) -> bytes:
        page = _PAGE.format(
            title=escape(str(openapi_schema["info"]["title"])),
            css=SWAGGER_CSS,
            js=SWAGGER_JS,
            init=SWAGGER_INIT_JS,
            openapi_url=escape(self.get_openapi_json_route(request)),
        )
        return page.encode()


def offline_openapi_plugins() -> list[OpenAPIRenderPlugin]:
    """For OpenAPIConfig(render_plugins=...): Swagger UI at /schema and /schema/swagger, the document as
    /schema/openapi.json and /schema/openapi.yaml (or .yml)."""
    return [OfflineSwaggerRenderPlugin(), JsonRenderPlugin(), YamlRenderPlugin()]
