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
