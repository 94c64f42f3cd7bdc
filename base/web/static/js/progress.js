// Live progress of an analysis over the API's server-sent events; the page reloads to show the result.
"use strict";

document.addEventListener("DOMContentLoaded", () => {
  const panel = document.querySelector("[data-events]");
  if (!panel || !window.EventSource) {
    return;
  }
  const bar = panel.querySelector("progress");
  const heading = panel.querySelector("[data-heading]");
  const message = panel.querySelector("[data-message]");
  const source = new EventSource(panel.dataset.events);
  const show = (event) => {
    const job = JSON.parse(event.data);
    bar.value = Math.round((job.fraction || 0) * 100);
    bar.textContent = `${bar.value} %`;
    heading.textContent = job.heading || `Analysis ${job.state}`;
    message.textContent = job.error || job.message || "";
  };
  source.addEventListener("progress", show);
  source.addEventListener("end", (event) => {
    show(event);
    source.close();
    window.location.reload();
  });
});
