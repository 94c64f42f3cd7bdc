// Building screens without inline script (the gateway's Content-Security-Policy forbids it): escaped templates,
// then listeners bound by selector.
export function esc(value) {
  return String(value ?? "").replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`);
}

class Raw {
  constructor(text) {
    this.text = text;
  }

  toString() {
    return this.text;
  }
}

const shown = (v) => (Array.isArray(v) ? v.map(shown).join("") : v instanceof Raw ? v.text : esc(v));

// A template whose values are escaped, unless they are themselves html`` (or raw()) results.
export function html(strings, ...values) {
  return new Raw(strings.reduce((out, s, i) => out + shown(values[i - 1]) + s));
}

export const raw = (text) => new Raw(text);

export function show(markup, binds = {}) {
  const screen = document.getElementById("screen");
  screen.innerHTML = String(markup);
  for (const [selector, handlers] of Object.entries(binds)) {
    for (const node of screen.querySelectorAll(selector)) {
      for (const [event, handler] of Object.entries(handlers)) node.addEventListener(event, handler);
    }
  }
  screen.focus();
  return screen;
}

export function banner(text, kind = "info") {
  const node = document.getElementById("banner");
  node.textContent = text ? text[0].toUpperCase() + text.slice(1) : "";
  node.className = `banner banner-${kind}`;
  node.hidden = !text;
}

export function formData(form) {
  const out = {};
  for (const [name, value] of new FormData(form).entries()) {
    if (name in out) out[name] = [].concat(out[name], value);
    else out[name] = value;
  }
  return out;
}

export function when(iso) {
  if (!iso) return "";
  const d = new Date(iso);
  return Number.isNaN(d.getTime()) ? iso : d.toLocaleString([], { dateStyle: "medium", timeStyle: "short" });
}

export function localInput(date = new Date()) {
  const pad = (n) => String(n).padStart(2, "0");
  return `${date.getFullYear()}-${pad(date.getMonth() + 1)}-${pad(date.getDate())}T${pad(date.getHours())}:${pad(date.getMinutes())}`;
}
