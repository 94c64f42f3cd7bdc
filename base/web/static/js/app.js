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

// Date-time fields are typed in the clinic's time. A device set to another zone is told so beside each of them
// (the page writes the clinic's offset on a hidden note; without this script the field's label names the zone).
function utcText(minutesEast) {
  const sign = minutesEast < 0 ? "-" : "+";
  const total = Math.abs(minutesEast);
  const pad = (n) => String(n).padStart(2, "0");
  return `UTC${sign}${pad(Math.floor(total / 60))}:${pad(total % 60)}`;
}
function checkZones(root) {
  const device = -new Date().getTimezoneOffset();
  root.querySelectorAll("[data-clinic-offset]").forEach((note) => {
    const clinic = Number(note.dataset.clinicOffset);
    if (Number.isNaN(clinic) || clinic === device) {
      note.hidden = true;
      return;
    }
    note.textContent =
      `This device is set to ${utcText(device)}; enter clinic time (${note.dataset.clinicOffsetText}).`;
    note.hidden = false;
  });
}
checkZones(document);
document.addEventListener("htmx:load", (event) => checkZones(event.target));

// On a phone the header folds into a Menu button, so the page's own content fills the first screen.
const header = document.querySelector(".site-header");
const menuButton = header && header.querySelector(".menu-toggle");
if (menuButton) {
  const menu = document.getElementById(menuButton.getAttribute("aria-controls"));
  header.classList.add("has-menu");
  menuButton.addEventListener("click", () => {
    const open = menu.classList.toggle("open");
    menuButton.setAttribute("aria-expanded", String(open));
  });
}

// A list (medications, allergies, comorbidities) shows one blank row; "Add another" shows the next. Without this
// script every blank row is shown, and a row left blank is dropped when the form is saved.
function listRows(root) {
  root.querySelectorAll("fieldset.field-list").forEach((list) => {
    if (list.dataset.rowsReady) {
      return;
    }
    list.dataset.rowsReady = "1";
    const blank = Array.from(list.querySelectorAll(":scope > [data-blank-row]"));
    if (blank.length < 2) {
      return;
    }
    blank.slice(1).forEach((row) => (row.hidden = true));
    const add = document.createElement("button");
    add.type = "button";
    add.className = "secondary add-row";
    add.textContent = `Add another ${(list.dataset.item || "row").toLowerCase()}`;
    add.addEventListener("click", () => {
      const next = blank.find((row) => row.hidden);
      if (next) {
        next.hidden = false;
        const first = next.querySelector("input, select, textarea");
        if (first) {
          first.focus();
        }
      }
      add.hidden = !blank.some((row) => row.hidden);
    });
    list.appendChild(add);
  });
}
listRows(document);
document.addEventListener("htmx:load", (event) => listRows(event.target));
