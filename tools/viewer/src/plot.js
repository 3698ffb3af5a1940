// The time plot under the scene (docs/viewer.md, "Time plot"): the mode strip, the
// pointing error (deg, log axis: detumble's tens of degrees and hold's hundredths both
// show) and the wheel speeds (or gimbal angles) as a fraction of their limit, drawn once
// into an offscreen canvas; each frame blits it and draws the cursor. A click seeks.

export const MODE_COLOURS = {
  detumble: '#cc79a7', sun_safe: '#e69f00', stabilise: '#56b4e9', manoeuvre: '#009e73', hold: '#0072b2',
};
const LINE_COLOURS = ['#d55e00', '#009e73', '#0072b2', '#cc79a7', '#e69f00', '#56b4e9', '#000000'];

export class TimePlot {
  constructor(canvas, replay, onSeek) {
    this.c = canvas;
    this.r = replay;
    this.pad = { l: 54, r: 10, top: 4, strip: 14, bottom: 16 };
    canvas.addEventListener('click', (ev) => {
      const rect = canvas.getBoundingClientRect();
      onSeek(this.timeAt(((ev.clientX - rect.left) * canvas.width) / rect.width));
    });
    this.draw();
  }

  x(t) {
    const { l, r } = this.pad;
    const w = this.c.width - l - r;
    return l + (w * (t - this.r.t0)) / Math.max(1e-12, this.r.t1 - this.r.t0);
  }

  timeAt(px) {
    const { l, r } = this.pad;
    const w = this.c.width - l - r;
    const f = Math.min(1, Math.max(0, (px - l) / w));
    return this.r.t0 + f * (this.r.t1 - this.r.t0);
  }

  draw() {
    const { c, r } = this;
    this.bg = document.createElement('canvas');
    this.bg.width = c.width; this.bg.height = c.height;
    const g = this.bg.getContext('2d');
    g.fillStyle = '#fff'; g.fillRect(0, 0, c.width, c.height);
    const T = r.t, n = r.n, p = this.pad;
    // Mode strip: one box per mode span.
    const mode = r.col('mode');
    if (mode) {
      let k0 = 0;
      for (let k = 1; k <= n; k++) {
        if (k === n || mode[k] !== mode[k0]) {
          const name = r.doc.modes[String(mode[k0])] || '?';
          g.fillStyle = MODE_COLOURS[name] || '#999';
          g.fillRect(this.x(T[k0]), p.top, Math.max(1, this.x(T[Math.min(k, n - 1)]) - this.x(T[k0])), p.strip);
          k0 = k;
        }
      }
    }
    const y0 = p.top + p.strip + 4, y1 = c.height - p.bottom;
    // Error, log axis from 1e-3 to 180 deg.
    const err = r.col('error_deg');
    const lo = -3, hi = Math.log10(180);
    const ye = (v) => y1 - ((Math.log10(Math.max(v, 1e-3)) - lo) / (hi - lo)) * (y1 - y0);
    g.strokeStyle = '#ddd'; g.fillStyle = '#444'; g.font = '10px sans-serif'; g.textAlign = 'right';
    for (let d = lo; d <= 2; d++) {
      g.beginPath(); g.moveTo(p.l, ye(10 ** d)); g.lineTo(c.width - p.r, ye(10 ** d)); g.stroke();
      g.fillText(`${10 ** d}°`, p.l - 3, ye(10 ** d) + 3);
    }
    const trace = (v, f, colour, width) => {
      g.strokeStyle = colour; g.lineWidth = width; g.beginPath();
      let pen = false;
      for (let k = 0; k < n; k++) {
        if (!Number.isFinite(v[k])) { pen = false; continue; }
        const X = this.x(T[k]), Y = f(v[k]);
        if (pen) g.lineTo(X, Y); else g.moveTo(X, Y);
        pen = true;
      }
      g.stroke();
    };
    // Wheel speeds (or gimbal angles) as a fraction of their limit on a linear ±1 axis.
    const yf = (v) => (y0 + y1) / 2 - (v * (y1 - y0)) / 2;
    const wheels = r.doc.spacecraft.wheels || [];
    wheels.forEach((w, i) => {
      const v = r.col(`wheel${i + 1}_speed_rpm`);
      if (v) trace(v, (x) => yf(x / w.max_speed_rpm), LINE_COLOURS[(i + 1) % LINE_COLOURS.length] + '99', 1);
    });
    r.names(/^gimbal\d+_deg$/).forEach((name, i) => trace(r.col(name), (x) => yf(x / 180), LINE_COLOURS[(i + 1) % 7] + '99', 1));
    if (err) trace(err, ye, '#000', 1.5);
    const primary = r.col('pointing_primary_error_deg');
    if (primary) trace(primary, ye, '#d55e00', 1.5);
    g.fillStyle = '#000'; g.textAlign = 'left';
    const legend = ['error (deg, log)'];
    if (primary) legend.push('primary axis (red)');
    if (wheels.length) legend.push('wheel speed / limit (±1, colours)');
    if (r.names(/^gimbal\d+_deg$/).length) legend.push('gimbal / 180°');
    g.fillText(legend.join(' · '), p.l + 4, c.height - 4);
    // Transitions: dashed grey lines.
    g.setLineDash([3, 3]); g.strokeStyle = '#888'; g.lineWidth = 1;
    for (const m of (r.doc.summary && r.doc.summary.mode_transitions) || []) {
      g.beginPath(); g.moveTo(this.x(m.t_s), p.top); g.lineTo(this.x(m.t_s), y1); g.stroke();
    }
    g.setLineDash([]);
  }

  frame(t) {
    const g = this.c.getContext('2d');
    g.drawImage(this.bg, 0, 0);
    g.strokeStyle = '#e00'; g.lineWidth = 2;
    g.beginPath(); g.moveTo(this.x(t), 0); g.lineTo(this.x(t), this.c.height); g.stroke();
  }
}
