// The 3D scene (docs/viewer.md, "Scene"). The world is the camera frame the user picks —
// inertial (ECI), LVLH or body — and every object is placed from ECI data through one
// quaternion F = world ← ECI: the spacecraft at F ⊗ q_body→ECI, the Sun and the Earth along
// F · (their ECI directions). Three.js quaternions are Hamilton, [x, y, z, w], and an
// object's quaternion rotates its local axes into its parent's: the project's convention
// (docs/conventions.md), so the run's quaternions go in as they are.
import * as THREE from 'three';

// Scene units from the spacecraft to the drawn Earth's centre: the globe is scaled to the
// Earth's true angular radius at that distance, so its surface stays a few spacecraft sizes
// away (at 500 km altitude: 30 × (1 − sin 66°) ≈ 2.6 units) and the body axes stay in view.
const EARTH_DISTANCE = 30;
const R_EARTH_M = 6378137.0;
/** World ← LVLH of the LVLH camera: half a turn about x (z nadir → world z zenith). */
const ZENITH_UP = new THREE.Quaternion(1, 0, 0, 0);

const C = {
  x: 0xd55e00, y: 0x009e73, z: 0x0072b2, // Okabe–Ito vermillion, bluish green, blue
  sun: 0xf0c000, lvlh: 0x888888, ghost: 0x56b4e9, wheel: 0xcc79a7, cmg: 0xe69f00,
  dipole: 0x7b3fe4, plume: 0xff7733, ok: 0x44aa44, bad: 0xff2222, target: 0xff44cc,
};

function arrow(dir, color, length, headLength = 0.12, headWidth = 0.06) {
  const a = new THREE.ArrowHelper(new THREE.Vector3(...dir).normalize(), new THREE.Vector3(), length, color, headLength, headWidth);
  return a;
}

function label(text, color) {
  const c = document.createElement('canvas');
  c.width = 128; c.height = 64;
  const g = c.getContext('2d');
  g.font = 'bold 40px sans-serif';
  g.fillStyle = color;
  g.textAlign = 'center';
  g.textBaseline = 'middle';
  g.fillText(text, 64, 32);
  const s = new THREE.Sprite(new THREE.SpriteMaterial({ map: new THREE.CanvasTexture(c), depthTest: false }));
  s.scale.set(0.4, 0.2, 1);
  return s;
}

/** The Earth: a sphere with a day/night terminator from the Sun direction (world frame),
 *  a graticule every 30° and a brighter equator and prime meridian, so its rotation shows. */
function earthGlobe() {
  const uniforms = { sunWorld: { value: new THREE.Vector3(1, 0, 0) } };
  const mat = new THREE.ShaderMaterial({
    uniforms,
    vertexShader: `
      varying vec3 vN; varying vec3 vP;
      void main() {
        vN = normalize(mat3(modelMatrix) * normal);
        vP = position;
        gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0);
      }`,
    fragmentShader: `
      uniform vec3 sunWorld; varying vec3 vN; varying vec3 vP;
      void main() {
        vec3 p = normalize(vP);
        float lat = degrees(asin(clamp(p.z, -1.0, 1.0)));
        float lon = degrees(atan(p.y, p.x));
        float grid = max(1.0 - smoothstep(0.0, 0.6, abs(mod(lat + 15.0, 30.0) - 15.0)),
                         1.0 - smoothstep(0.0, 0.6, abs(mod(lon + 15.0, 30.0) - 15.0)));
        float main = max(1.0 - smoothstep(0.0, 0.9, abs(lat)), 1.0 - smoothstep(0.0, 0.9, abs(lon)));
        float day = smoothstep(-0.03, 0.03, dot(normalize(vN), normalize(sunWorld)));
        vec3 ocean = mix(vec3(0.02, 0.03, 0.08), vec3(0.12, 0.35, 0.75), day);
        vec3 c = ocean + 0.25 * grid * vec3(1.0) + 0.5 * main * vec3(1.0, 0.9, 0.4) * (0.3 + 0.7 * day);
        gl_FragColor = vec4(c, 1.0);
      }`,
  });
  const mesh = new THREE.Mesh(new THREE.SphereGeometry(1, 96, 48), mat);
  return { mesh, uniforms };
}

function cone(halfAngleDeg, length, color, opacity) {
  const r = length * Math.tan((Math.min(halfAngleDeg, 89) * Math.PI) / 180);
  const g = new THREE.ConeGeometry(r, length, 48, 1, true);
  // Apex at the origin, opening along +y, then turned to +z (the boresight's local axis).
  g.translate(0, -length / 2, 0);
  g.rotateX(-Math.PI / 2);
  const m = new THREE.MeshBasicMaterial({ color, transparent: true, opacity, side: THREE.DoubleSide, depthWrite: false });
  return new THREE.Mesh(g, m);
}

/** Rotation taking +z to `axis` (unit). */
function fromZ(axis) {
  return new THREE.Quaternion().setFromUnitVectors(new THREE.Vector3(0, 0, 1), new THREE.Vector3(...axis).normalize());
}

export class Scene {
  constructor(replay) {
    this.r = replay;
    const sc = replay.doc.spacecraft;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x05070d);
    this.scene.add(new THREE.AmbientLight(0xffffff, 0.35));
    this.sunLight = new THREE.DirectionalLight(0xffffff, 2.0);
    this.scene.add(this.sunLight);

    const box = sc.box_m;
    this.scale = 1 / Math.max(...box); // longest side = 1 scene unit
    this.craft = new THREE.Group();
    const dims = box.map((b) => b * this.scale);
    const body = new THREE.Mesh(
      new THREE.BoxGeometry(...dims),
      new THREE.MeshStandardMaterial({ color: 0xb8bcc8, metalness: 0.3, roughness: 0.6 }),
    );
    this.craft.add(body);
    this.craft.add(new THREE.LineSegments(new THREE.EdgesGeometry(body.geometry), new THREE.LineBasicMaterial({ color: 0x222222 })));
    [[1, 0, 0, C.x, 'x'], [0, 1, 0, C.y, 'y'], [0, 0, 1, C.z, 'z']].forEach(([a, b, c, col, name]) => {
      this.craft.add(arrow([a, b, c], col, 1.0));
      const l = label(name, '#' + col.toString(16).padStart(6, '0'));
      l.position.set(a * 1.1, b * 1.1, c * 1.1);
      this.craft.add(l);
    });
    this.scene.add(this.craft);
    this.buildActuators(sc);
    this.buildBoresights(sc);
    this.buildGhost(dims);
    this.buildEnvironment();
    this.buildTarget();
  }

  /** The tracked ground target or station (`[guidance]` runs record its direction in body
   *  axes, `target_body_*`): a magenta ray from the spacecraft to where it meets the drawn
   *  Earth, with a marker there; pale while the site is below its elevation mask. */
  buildTarget() {
    this.hasTarget = this.r.has('target_body_x');
    this.targetRay = arrow([1, 0, 0], C.target, 3, 0.12, 0.06);
    this.targetMark = new THREE.Mesh(new THREE.SphereGeometry(0.09, 16, 8), new THREE.MeshBasicMaterial({ color: C.target }));
    this.scene.add(this.targetRay, this.targetMark);
    this.targetRay.visible = this.targetMark.visible = false;
  }

  updateTarget(loc) {
    this.target = null;
    const v = this.hasTarget ? this.r.vec3('target_body_', loc) : [NaN];
    const ok = v.every(Number.isFinite) && Math.hypot(...v) > 0;
    this.targetRay.visible = this.targetMark.visible = ok;
    if (!ok) return;
    const dir = new THREE.Vector3(...v).normalize().applyQuaternion(this.craft.quaternion);
    // Nearest intersection of the ray with the drawn globe, else 3 scene units.
    let len = 3;
    if (this.hasOrbit) {
      const c = this.earth.position, R = this.earth.scale.x;
      const b = dir.dot(c), disc = b * b - (c.lengthSq() - R * R);
      if (disc >= 0 && b - Math.sqrt(disc) > 0) len = b - Math.sqrt(disc);
    }
    this.targetRay.setDirection(dir);
    this.targetRay.setLength(len, 0.12, 0.06);
    this.targetMark.position.copy(dir.clone().multiplyScalar(len));
    const visible = this.r.value('target_visible', loc) === 1;
    const colour = visible ? C.target : 0x804070;
    this.targetRay.setColor(colour);
    this.targetMark.material.color.setHex(colour);
    this.target = { world: dir, visible };
  }

  buildActuators(sc) {
    this.wheels = sc.wheels.map((w, i) => {
      const a = arrow(w.axis, C.wheel, 0.6, 0.1, 0.06);
      this.craft.add(a);
      return { a, axis: new THREE.Vector3(...w.axis).normalize(), max: w.max_speed_rpm, col: `wheel${i + 1}_speed_rpm` };
    });
    this.cmgs = sc.cmgs.map((u, i) => {
      const g = new THREE.Vector3(...u.gimbal).normalize();
      const base = g.clone().multiplyScalar(0.45);
      const gimbal = new THREE.Line(
        new THREE.BufferGeometry().setFromPoints([base.clone().sub(g.clone().multiplyScalar(0.15)), base.clone().add(g.clone().multiplyScalar(0.15))]),
        new THREE.LineBasicMaterial({ color: 0x444444 }),
      );
      const spin = arrow(u.spin0, C.cmg, 0.35, 0.08, 0.05);
      spin.position.copy(base);
      this.craft.add(gimbal, spin);
      return { spin, s0: new THREE.Vector3(...u.spin0), t0: new THREE.Vector3(...u.trans0), col: `gimbal${i + 1}_deg` };
    });
    this.maxDipole = Math.max(1e-12, ...sc.magnetorquers.map((m) => m.max_am2));
    this.dipole = sc.magnetorquers.length ? arrow([1, 0, 0], C.dipole, 0.5) : null;
    if (this.dipole) this.craft.add(this.dipole);
    this.plumes = sc.thrusters.map((t, i) => {
      const p = t.torque_only ? new THREE.Vector3(...t.direction).multiplyScalar(-0.5) : new THREE.Vector3(...t.position_m).multiplyScalar(this.scale);
      const m = cone(14, 0.35, C.plume, 0.8);
      // The plume leaves opposite to the force on the body.
      m.quaternion.copy(fromZ(t.direction.map((x) => -x)));
      m.position.copy(p);
      m.visible = false;
      this.craft.add(m);
      return { m, i };
    });
  }

  buildBoresights(sc) {
    this.boresights = sc.boresights.map((b) => {
      const g = new THREE.Group();
      g.quaternion.copy(fromZ(b.axis_body));
      const line = new THREE.Line(
        new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(0, 0, 0), new THREE.Vector3(0, 0, 2.2)]),
        new THREE.LineBasicMaterial({ color: 0xffffff }),
      );
      g.add(line);
      const cones = [];
      if (b.sun_exclusion_deg != null) cones.push({ kind: 'sun', half: b.sun_exclusion_deg, m: cone(b.sun_exclusion_deg, 1.6, C.sun, 0.18) });
      if (b.earth_exclusion_deg != null) cones.push({ kind: 'earth', half: b.earth_exclusion_deg, m: cone(b.earth_exclusion_deg, 1.3, 0x3080ff, 0.15) });
      if (b.fov_deg != null) cones.push({ kind: 'fov', half: b.fov_deg, m: cone(b.fov_deg, 0.8, 0xffffff, 0.08) });
      cones.forEach((c) => g.add(c.m));
      this.craft.add(g);
      return { name: b.name, axis: new THREE.Vector3(...b.axis_body).normalize(), cones };
    });
  }

  buildGhost(dims) {
    this.ghost = new THREE.Group();
    const edges = new THREE.EdgesGeometry(new THREE.BoxGeometry(...dims.map((d) => d * 1.04)));
    this.ghost.add(new THREE.LineSegments(edges, new THREE.LineBasicMaterial({ color: C.ghost, transparent: true, opacity: 0.9 })));
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]].forEach((d) => this.ghost.add(arrow(d, C.ghost, 0.8, 0.08, 0.04)));
    this.ghost.visible = this.r.has('geo_q_target_w');
    this.scene.add(this.ghost);
  }

  buildEnvironment() {
    this.hasOrbit = this.r.has('geo_sun_eci_x');
    this.sunArrow = arrow([1, 0, 0], C.sun, 2.6, 0.2, 0.1);
    this.sunBall = new THREE.Mesh(new THREE.SphereGeometry(0.25, 24, 12), new THREE.MeshBasicMaterial({ color: C.sun }));
    this.scene.add(this.sunArrow, this.sunBall);
    const e = earthGlobe();
    this.earth = e.mesh;
    this.earthUniforms = e.uniforms;
    this.scene.add(this.earth);
    this.lvlh = new THREE.Group();
    [[1, 0, 0, 'x̂ along'], [0, 1, 0, 'ŷ'], [0, 0, 1, 'ẑ nadir']].forEach(([a, b, c]) => this.lvlh.add(arrow([a, b, c], C.lvlh, 1.5, 0.1, 0.05)));
    this.scene.add(this.lvlh);
    for (const o of [this.sunArrow, this.sunBall, this.earth, this.lvlh]) o.visible = this.hasOrbit;
  }

  /** World ← ECI for the camera frame at this time. */
  frameQuat(camera, qBody, qLvlh) {
    if (camera === 'body') return new THREE.Quaternion(...qBody).invert();
    // LVLH drawn with the zenith up (world z = −LVLH z, x along track): the Earth below.
    if (camera === 'lvlh' && qLvlh) return ZENITH_UP.clone().multiply(new THREE.Quaternion(...qLvlh).invert());
    return new THREE.Quaternion();
  }

  /** Places everything at time t (located by the replay) for the camera frame. */
  update(loc, camera) {
    const r = this.r;
    const qBody = r.quat('q_', loc);
    const qLvlh = this.hasOrbit ? r.quat('geo_q_lvlh_', loc) : null;
    const F = this.frameQuat(camera, qBody, qLvlh);
    this.F = F;
    this.craft.quaternion.copy(F).multiply(new THREE.Quaternion(...qBody));
    if (this.ghost.visible) this.ghost.quaternion.copy(F).multiply(new THREE.Quaternion(...r.quat('geo_q_target_', loc)));
    this.updateActuators(loc);
    if (this.hasOrbit) this.updateEnvironment(loc, F, qLvlh);
    this.updateBoresights(loc);
    this.updateTarget(loc);
  }

  updateActuators(loc) {
    const r = this.r;
    for (const w of this.wheels) {
      const s = r.value(w.col, loc);
      const f = Math.min(1, Math.abs(s) / w.max) || 0;
      w.a.setDirection(w.axis.clone().multiplyScalar(s < 0 ? -1 : 1));
      w.a.setLength(0.15 + 0.85 * f, 0.1, 0.06);
      // Colour: green (slow) → orange → red at the speed limit.
      w.a.setColor(new THREE.Color().setHSL(0.33 * (1 - f), 0.9, 0.5));
    }
    for (const u of this.cmgs) {
      const d = (r.value(u.col, loc) * Math.PI) / 180;
      u.spin.setDirection(u.s0.clone().multiplyScalar(Math.cos(d)).add(u.t0.clone().multiplyScalar(Math.sin(d))));
    }
    if (this.dipole) {
      const m = r.vec3('dipole_', loc, '_am2');
      const n = Math.hypot(...m);
      this.dipole.visible = n > 0 && Number.isFinite(n);
      if (this.dipole.visible) {
        this.dipole.setDirection(new THREE.Vector3(...m).normalize());
        this.dipole.setLength(0.2 + Math.min(1.5, n / this.maxDipole), 0.1, 0.06);
      }
    }
    const mask = r.value('thrusters_on', loc);
    for (const p of this.plumes) {
      const level = r.value(`thruster${p.i + 1}_level`, loc);
      p.m.visible = level > 0 || (Number.isFinite(mask) && (mask & (1 << p.i)) !== 0);
    }
  }

  updateEnvironment(loc, F, qLvlh) {
    const r = this.r;
    const sun = new THREE.Vector3(...r.vec3('geo_sun_eci_', loc)).normalize().applyQuaternion(F);
    const earth = new THREE.Vector3(...r.vec3('geo_earth_eci_', loc)).normalize().applyQuaternion(F);
    const rho = r.value('geo_earth_radius_rad', loc);
    this.sunArrow.setDirection(sun);
    this.sunBall.position.copy(sun.clone().multiplyScalar(2.9));
    this.sunLight.position.copy(sun.clone().multiplyScalar(10));
    const eclipse = r.value('geo_eclipse', loc) === 1;
    this.sunLight.intensity = eclipse ? 0.05 : 2.0;
    this.earth.position.copy(earth.clone().multiplyScalar(EARTH_DISTANCE));
    // Radius so the globe subtends the Earth's true angular radius seen from the craft.
    const s = EARTH_DISTANCE * Math.sin(rho);
    this.earth.scale.set(s, s, s);
    const theta = r.value('geo_earth_rotation_rad', loc);
    this.earth.quaternion.copy(F).multiply(new THREE.Quaternion().setFromAxisAngle(new THREE.Vector3(0, 0, 1), theta));
    this.earthUniforms.sunWorld.value.copy(sun);
    this.lvlh.quaternion.copy(F).multiply(new THREE.Quaternion(...qLvlh));
    this.eclipse = eclipse;
  }

  /** Each boresight's margin to each of its cones, deg (negative inside: a violation),
   *  from the scene's own objects; a violated cone is drawn red. */
  updateBoresights(loc) {
    this.keepout = [];
    if (!this.hasOrbit) return;
    const sun = new THREE.Vector3(...this.r.vec3('geo_sun_eci_', loc)).normalize().applyQuaternion(this.F);
    const earthC = this.earth.position.clone().normalize();
    const rhoDeg = (Math.asin(this.earth.scale.x / EARTH_DISTANCE) * 180) / Math.PI;
    for (const b of this.boresights) {
      const axis = b.axis.clone().applyQuaternion(this.craft.quaternion);
      for (const c of b.cones) {
        if (c.kind === 'fov') continue;
        // Sun: angle to the Sun's centre; Earth: to the nearest point of the limb.
        const ang = c.kind === 'sun'
          ? (axis.angleTo(sun) * 180) / Math.PI
          : (axis.angleTo(earthC) * 180) / Math.PI - rhoDeg;
        const margin = ang - c.half;
        c.m.material.color.setHex(margin < 0 ? C.bad : c.kind === 'sun' ? C.sun : 0x3080ff);
        c.m.material.opacity = margin < 0 ? 0.45 : c.kind === 'sun' ? 0.18 : 0.15;
        this.keepout.push({ boresight: b.name, cone: c.kind, margin_deg: margin, violated: margin < 0 });
      }
    }
  }
}

/** The orbit view: the Earth at scale (radius 1), the orbit, the spacecraft on it and the
 *  ground track, in ECI with the Earth turning under them. */
export class OrbitScene {
  constructor(replay) {
    this.r = replay;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0x05070d);
    this.ok = replay.has('geo_r_eci_x_m');
    if (!this.ok) return;
    const e = earthGlobe();
    this.earth = e.mesh;
    this.uniforms = e.uniforms;
    this.scene.add(this.earth);
    const n = replay.n;
    const X = replay.col('geo_r_eci_x_m'), Y = replay.col('geo_r_eci_y_m'), Z = replay.col('geo_r_eci_z_m');
    const TH = replay.col('geo_earth_rotation_rad');
    const orbit = new Float32Array(3 * n), track = new Float32Array(3 * n);
    for (let i = 0; i < n; i++) {
      const x = X[i] / R_EARTH_M, y = Y[i] / R_EARTH_M, z = Z[i] / R_EARTH_M;
      orbit.set([x, y, z], 3 * i);
      // ECEF: rotate by -θ about z; then onto the surface.
      const c = Math.cos(TH[i]), s = Math.sin(TH[i]);
      const xe = c * x + s * y, ye = -s * x + c * y, ne = Math.hypot(xe, ye, z);
      track.set([(1.003 * xe) / ne, (1.003 * ye) / ne, (1.003 * z) / ne], 3 * i);
    }
    const line = (pts, color) => {
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(pts, 3));
      return new THREE.Line(g, new THREE.LineBasicMaterial({ color }));
    };
    // The last orbital period up to the current time: over days a whole track would cover
    // the globe (J2 turns the plane, the Earth turns under it).
    this.orbitLine = line(orbit, 0x88aaff);
    this.trackLine = line(track, 0xffdd55);
    this.scene.add(this.orbitLine);
    this.earth.add(this.trackLine); // turns with the Earth
    this.craft = new THREE.Mesh(new THREE.SphereGeometry(0.04, 16, 8), new THREE.MeshBasicMaterial({ color: 0xff5533 }));
    this.scene.add(this.craft);
    this.sun = arrow([1, 0, 0], C.sun, 2.2, 0.15, 0.08);
    this.scene.add(this.sun);
  }

  update(loc) {
    if (!this.ok) return;
    const r = this.r;
    const p = r.vec3('geo_r_eci_', loc, '_m').map((x) => x / R_EARTH_M);
    // Period of the circular orbit of this radius (μ = GM of the Earth, WGS 84).
    const period_s = 2 * Math.PI * Math.sqrt((Math.hypot(...p) * R_EARTH_M) ** 3 / 3.986004418e14);
    const t = r.t[loc.k] + loc.a * ((r.t[loc.k + 1] ?? r.t[loc.k]) - r.t[loc.k]);
    const k0 = r.locate(t - period_s).k;
    const count = Math.max(2, loc.k + 2 - k0);
    this.orbitLine.geometry.setDrawRange(k0, count);
    this.trackLine.geometry.setDrawRange(k0, count);
    this.craft.position.set(...p);
    const sun = new THREE.Vector3(...r.vec3('geo_sun_eci_', loc)).normalize();
    this.sun.setDirection(sun);
    this.uniforms.sunWorld.value.copy(sun);
    this.earth.quaternion.setFromAxisAngle(new THREE.Vector3(0, 0, 1), r.value('geo_earth_rotation_rad', loc));
  }
}
