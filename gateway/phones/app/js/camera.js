// The rear camera in the browser, and stills at the camera's own resolution (ImageCapture when the browser has it,
// else the full video frame). A phone without camera access in the browser uses the file input instead.
export function hasCamera() {
  return Boolean(navigator.mediaDevices?.getUserMedia) && window.isSecureContext;
}

export async function openCamera(video) {
  const stream = await navigator.mediaDevices.getUserMedia({
    audio: false,
    // A preview of moderate size keeps the per-frame checks cheap; stills come at the camera's full resolution
    // from ImageCapture (below), not from the preview.
    video: { facingMode: { ideal: "environment" }, width: { ideal: 1920 }, height: { ideal: 1440 } },
  });
  video.srcObject = stream;
  await video.play();
  return stream;
}

export function closeCamera(stream) {
  for (const track of stream?.getTracks() || []) track.stop();
}

export async function still(video, stream) {
  const track = stream.getVideoTracks()[0];
  if ("ImageCapture" in window && track) {
    try {
      const capture = new window.ImageCapture(track);
      const largest = await capture.getPhotoCapabilities().then(
        (c) => ({ imageWidth: c.imageWidth?.max, imageHeight: c.imageHeight?.max }),
        () => ({}),
      );
      const blob = await capture.takePhoto(largest.imageWidth ? largest : undefined);
      if (blob?.size) return blob;
    } catch {
      // some cameras take no photos through ImageCapture: the video frame below is the still
    }
  }
  const canvas = document.createElement("canvas");
  canvas.width = video.videoWidth;
  canvas.height = video.videoHeight;
  canvas.getContext("2d").drawImage(video, 0, 0);
  return new Promise((resolve, reject) => {
    canvas.toBlob((blob) => (blob ? resolve(blob) : reject(new Error("the camera gave no picture"))), "image/jpeg", 0.92);
  });
}
