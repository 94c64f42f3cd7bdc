// Starts the vendored Swagger UI on /schema (base/web/pages/api_docs.py renders the page).
// The schema's address comes from the page's data-openapi-url attribute, so the page needs no inline script.
"use strict";

(function () {
  const root = document.getElementById("swagger-ui");
  window.ui = SwaggerUIBundle({
    url: root.dataset.openapiUrl,
    domNode: root,
    deepLinking: true,
    showExtensions: true,
    showCommonExtensions: true,
    // null: no badge from validator.swagger.io, the page asks nothing of any other host.
    validatorUrl: null,
    presets: [SwaggerUIBundle.presets.apis],
    layout: "BaseLayout",
  });
})();
