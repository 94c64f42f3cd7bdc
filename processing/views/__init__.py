"""Drawings for the browser pages: SVG markup made on the server (the burn chart, the healing plots), readable
without JavaScript, every text escaped, no inline style or script."""
