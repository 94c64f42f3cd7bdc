// Resumable uploads from the pictures page with the vendored tus client; without scripts the form posts as usual.
"use strict";

document.addEventListener("DOMContentLoaded", () => {
  const form = document.querySelector("form[data-tus-upload]");
  if (!form || !window.tus || !window.tus.isSupported) {
    return;
  }
  const input = form.querySelector("input[type=file]");
  const progress = form.querySelector("[data-upload-progress]");
  const token = document.body.dataset.csrfToken;
  const wound = form.querySelector("select[name=wound_id]");
  // The wound picked on the form travels in the upload's metadata; none picked says nothing.
  const wounded = (metadata) => (wound && wound.value ? { ...metadata, wound_id: wound.value } : metadata);

  const line = (file) => {
    const row = document.createElement("p");
    const label = document.createElement("label");
    const bar = document.createElement("progress");
    bar.max = 100;
    bar.value = 0;
    bar.id = `upload-${progress.children.length}`;
    label.htmlFor = bar.id;
    label.textContent = `${file.name} `;
    row.append(label, bar);
    const status = document.createElement("span");
    status.className = "muted";
    row.append(" ", status);
    progress.append(row);
    return { bar, status };
  };

  const send = (file) =>
    new Promise((resolve) => {
      const { bar, status } = line(file);
      const upload = new window.tus.Upload(file, {
        endpoint: "/api/v1/uploads",
        chunkSize: 4 * 1024 * 1024,
        retryDelays: [0, 1000, 3000, 5000, 10000, 20000, 30000, 60000],
        removeFingerprintOnSuccess: true,
        headers: { "X-CSRF-Token": token },
        metadata: wounded({ encounter_id: form.dataset.encounterId, filename: file.name, filetype: file.type }),
        onProgress: (sent, total) => {
          bar.value = total ? Math.floor((100 * sent) / total) : 0;
        },
        onError: (error) => {
          status.textContent = `not stored: ${error.message || error}`;
          resolve(false);
        },
        onSuccess: () => {
          bar.value = 100;
          status.textContent = "stored";
          resolve(true);
        },
      });
      // A file whose upload was cut off earlier continues where the gateway stopped receiving it.
      upload.findPreviousUploads().then((previous) => {
        if (previous.length) {
          upload.resumeFromPreviousUpload(previous[0]);
          status.textContent = "resuming";
        }
        upload.start();
      });
    });

  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    const files = Array.from(input.files || []);
    if (!files.length) {
      input.focus();
      return;
    }
    form.querySelector("button[type=submit]").disabled = true;
    let allStored = true;
    for (const file of files) {
      allStored = (await send(file)) && allStored;
    }
    if (allStored) {
      window.location.reload();
    } else {
      form.querySelector("button[type=submit]").disabled = false;
    }
  });
});
