// Enhancements only: every page works without this file.
"use strict";

// Buttons with data-confirm ask before their form is sent (withdrawing, sending a case).
document.addEventListener("submit", (event) => {
  const button = event.submitter;
  const text = (button && button.dataset.confirm) || event.target.dataset.confirm;
  if (text && !window.confirm(text)) {
    event.preventDefault();
  }
});

// A region of the burn chart's SVG body diagram opens its editor in place (the link still works without this).
document.addEventListener("click", (event) => {
  const link = event.target.closest && event.target.closest("[data-chart-area] a[href]");
  if (!link || !window.htmx || event.ctrlKey || event.metaKey || event.shiftKey) {
    return;
  }
  event.preventDefault();
  const href = link.getAttribute("href") || link.getAttribute("xlink:href");
  window.htmx.ajax("GET", href, { target: "#chart-area", swap: "outerHTML" }).then(() => {
    const first = document.querySelector("#chart-area form input:not([type=hidden])");
    if (first) {
      first.focus();
    }
  });
});

// A partial update that failed (the gateway refused it or is unreachable) says so instead of doing nothing.
document.addEventListener("htmx:responseError", (event) => {
  const status = event.detail.xhr ? event.detail.xhr.status : 0;
  window.alert(`Not saved (error ${status}). Reload the page and try again.`);
});
document.addEventListener("htmx:sendError", () => {
  window.alert("The gateway did not answer. Check the Wi-Fi, then try again.");
});
