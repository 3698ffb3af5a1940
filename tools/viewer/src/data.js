// The run's data as the page reads it (docs/viewer.md, "Data layout"): the JSON document
// `sim-host view` embeds, its channels decoded from base64 into typed arrays, and the
// values of any channel at any time (exact at a kept row; between rows linear, slerp for
// quaternions, the earlier row's level for step channels).

export const FORMAT_VERSION = 1;

/** Step channels: held, never interpolated (sim-host/src/view/mod.rs STEP_CHANNELS). */
export const STEP_CHANNELS = new Set([
  'mode', 'status', 'eclipse', 'thrusters_on', 'target_visible', 'pointing_segment', 'geo_eclipse',
]);

function decode(ch) {
  const bin = atob(ch.data);
  const bytes = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) bytes[i] = bin.charCodeAt(i);
  // The encoder writes little-endian; so do the machines browsers run on, but say so.
  const view = new DataView(bytes.buffer);
  if (ch.dtype === 'f64') {
    const out = new Float64Array(bytes.length / 8);
    for (let i = 0; i < out.length; i++) out[i] = view.getFloat64(8 * i, true);
    return out;
  }
  const out = new Float32Array(bytes.length / 4);
  for (let i = 0; i < out.length; i++) out[i] = view.getFloat32(4 * i, true);
  return out;
}

export class Replay {
  constructor(doc) {
    if (doc.format_version !== FORMAT_VERSION) {
      throw new Error(`replay data format ${doc.format_version}, this page reads ${FORMAT_VERSION}`);
    }
    this.doc = doc;
    this.ch = new Map();
    this.units = new Map();
    for (const c of doc.channels) {
      this.ch.set(c.name, decode(c));
      this.units.set(c.name, c.unit);
    }
    this.t = this.ch.get('t_s');
    if (!this.t || this.t.length === 0) throw new Error('the replay has no t_s channel');
    this.n = this.t.length;
    this.t0 = this.t[0];
    this.t1 = this.t[this.n - 1];
  }

  has(name) { return this.ch.has(name); }
  col(name) { return this.ch.get(name); }
  /** Names matching a pattern, in document order. */
  names(re) { return this.doc.channels.map((c) => c.name).filter((n) => re.test(n)); }

  /** The row k with t[k] <= t < t[k+1] (clamped) and the fraction towards k+1. */
  locate(t) {
    const T = this.t;
    if (t <= T[0]) return { k: 0, a: 0 };
    if (t >= T[this.n - 1]) return { k: this.n - 1, a: 0 };
    let lo = 0, hi = this.n - 1;
    while (hi - lo > 1) {
      const mid = (lo + hi) >> 1;
      if (T[mid] <= t) lo = mid; else hi = mid;
    }
    const a = (t - T[lo]) / (T[lo + 1] - T[lo]);
    return { k: lo, a };
  }

  /** A scalar channel at a located time (NaN when absent). */
  value(name, loc) {
    const c = this.ch.get(name);
    if (!c) return NaN;
    const { k, a } = loc;
    if (a === 0 || STEP_CHANNELS.has(name)) return c[k];
    return c[k] + a * (c[k + 1] - c[k]);
  }

  /** A 3-vector from channels `prefix + x|y|z + suffix`. */
  vec3(prefix, loc, suffix = '') {
    return ['x', 'y', 'z'].map((ax) => this.value(prefix + ax + suffix, loc));
  }

  /** A unit quaternion [x, y, z, w] from channels `prefix + x|y|z|w`: the row's own values
   *  at a row, the shortest-arc slerp between rows. */
  quat(prefix, loc) {
    const get = (k) => ['x', 'y', 'z', 'w'].map((ax) => this.ch.get(prefix + ax)[k]);
    const { k, a } = loc;
    const q0 = get(k);
    if (a === 0) return q0;
    return slerp(q0, get(k + 1), a);
  }
}

/** Shortest-arc spherical interpolation of [x, y, z, w] quaternions. */
export function slerp(p, q, a) {
  let d = p[0] * q[0] + p[1] * q[1] + p[2] * q[2] + p[3] * q[3];
  const s = d < 0 ? -1 : 1;
  d = Math.abs(d);
  let w0, w1;
  if (d > 0.9999995) {
    w0 = 1 - a; w1 = a;
  } else {
    const th = Math.acos(d), sn = Math.sin(th);
    w0 = Math.sin((1 - a) * th) / sn; w1 = Math.sin(a * th) / sn;
  }
  const r = p.map((x, i) => w0 * x + s * w1 * q[i]);
  const n = Math.hypot(...r);
  return r.map((x) => x / n);
}

/** The embedded document: the script element `#acs-replay-data`. */
export function embedded() {
  return globalThis.ACS_REPLAY_DATA;
}
