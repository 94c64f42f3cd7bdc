// Outline and ruler points clicked on a photo, written into the form's text inputs as "x, y; x, y" in pixels of
// the full photo. Without scripts the inputs are typed by hand.
"use strict";

document.addEventListener("DOMContentLoaded", () => {
  for (const item of document.querySelectorAll("[data-annotate]")) {
    const thumb = item.querySelector("img");
    const inputs = item.querySelectorAll("input[data-kind]");
    let active = inputs[0];
    for (const input of inputs) {
      input.addEventListener("focus", () => {
        active = input;
      });
    }
    const open = () => {
      if (item.querySelector(".annotate-canvas")) {
        return;
      }
      const frame = document.createElement("div");
      frame.className = "annotate-canvas";
      const full = document.createElement("img");
      full.src = item.dataset.src;
      full.alt = `${thumb.alt}, full size: click to add a point`;
      const help = document.createElement("p");
      help.className = "hint";
      help.textContent = "Click to add a point to the field you last chose (outline or ruler).";
      const clear = document.createElement("button");
      clear.type = "button";
      clear.className = "secondary";
      clear.textContent = "Clear that field";
      clear.addEventListener("click", () => {
        active.value = "";
      });
      full.addEventListener("click", (event) => {
        const box = full.getBoundingClientRect();
        const x = Math.round(((event.clientX - box.left) * full.naturalWidth) / box.width);
        const y = Math.round(((event.clientY - box.top) * full.naturalHeight) / box.height);
        active.value = active.value.trim() ? `${active.value.trim()}; ${x}, ${y}` : `${x}, ${y}`;
      });
      frame.append(full, help, clear);
      item.append(frame);
    };
    thumb.tabIndex = 0;
    thumb.addEventListener("click", open);
    thumb.addEventListener("keydown", (event) => {
      if (event.key === "Enter" || event.key === " ") {
        event.preventDefault();
        open();
      }
    });
  }
});
