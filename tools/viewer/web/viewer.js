// fieldline viewer page: draws /field.json once and every state pushed on /ws (see
// docs/viewer.md for the document), and the selected robot's camera from /camera.json.
// Field frame: x toward the opponent goal (right), y left (up).
"use strict";

const STATUS_NAMES = ["unknown", "searching", "tracking", "odometry only"];
// Fill colour of an estimate by robot_state_t status.
const STATUS_COLOURS = ["#888888", "#ff9f1c", "#2ecc71", "#f1c40f"];
// One colour per robot number, for its outline, ball and line points.
const ROBOT_COLOURS = ["", "#e74c3c", "#3498db", "#9b59b6", "#1abc9c", "#e67e22", "#ecf0f1"];
const PROCESS_STATES = ["ok", "warn", "error"];
// Chi-square 95 % quantile for 2 degrees of freedom: the ellipse holds 95 % of the position.
const ELLIPSE_SCALE = Math.sqrt(5.991);
const ROBOT_RADIUS = 0.25;  // m, drawn when SIM_WORLD does not say

const canvas = document.getElementById("field");
const ctx = canvas.getContext("2d");
const select = document.getElementById("select");
let field = null;
let state = null;
let selected = 1;
// The last state is kept here for tests and the browser console.
window.fieldlineState = null;

select.addEventListener("change", () => { selected = Number(select.value); draw(); });

function view() {
  const half = field ? field.carpet_half_extent : [12, 8];
  const scale = Math.min(canvas.width / (2 * half[0] + 0.4), canvas.height / (2 * half[1] + 0.4));
  return {
    scale,
    px: (x) => canvas.width / 2 + x * scale,
    py: (y) => canvas.height / 2 - y * scale,
  };
}

function drawField(v) {
  ctx.fillStyle = "#2e7d32";
  const h = field.carpet_half_extent;
  ctx.fillRect(v.px(-h[0]), v.py(h[1]), 2 * h[0] * v.scale, 2 * h[1] * v.scale);
  ctx.strokeStyle = "#ffffff";
  for (const s of field.segments) {
    ctx.lineWidth = Math.max(1, s.width * v.scale);
    ctx.beginPath();
    ctx.moveTo(v.px(s.a[0]), v.py(s.a[1]));
    ctx.lineTo(v.px(s.b[0]), v.py(s.b[1]));
    ctx.stroke();
  }
  for (const a of field.arcs) {
    ctx.lineWidth = Math.max(1, a.width * v.scale);
    ctx.beginPath();
    // The canvas's y points down, so field angles turn clockwise on screen.
    ctx.arc(v.px(a.centre[0]), v.py(a.centre[1]), a.radius * v.scale, -a.start_angle,
            -(a.start_angle + a.sweep), true);
    ctx.stroke();
  }
  for (const g of field.goals) {
    const colour = { yellow: "#f1c40f", blue: "#2471a3", white: "#eeeeee" }[g.colour];
    ctx.fillStyle = colour || "#cccccc";
    const x0 = g.mouth_centre[0], x1 = x0 + g.outward[0] * g.depth;
    ctx.fillRect(v.px(Math.min(x0, x1)), v.py(g.mouth_centre[1] + g.width / 2),
                 Math.abs(x1 - x0) * v.scale, g.width * v.scale);
  }
  ctx.fillStyle = "#ffffff";
  for (const m of field.penalty_marks) {
    ctx.beginPath();
    ctx.arc(v.px(m[0]), v.py(m[1]), Math.max(1.5, field.penalty_mark_diameter / 2 * v.scale), 0,
            2 * Math.PI);
    ctx.fill();
  }
}

// The 95 % ellipse of the 2x2 covariance [a b; b c] (row-major, field frame) around (x, y).
function drawEllipse(v, x, y, a, b, c, colour) {
  if (![a, b, c].every(Number.isFinite) || a < 0 || c < 0) return;
  const mean = (a + c) / 2, diff = Math.sqrt(((a - c) / 2) ** 2 + b * b);
  const major = Math.sqrt(Math.max(0, mean + diff)), minor = Math.sqrt(Math.max(0, mean - diff));
  const angle = 0.5 * Math.atan2(2 * b, a - c);
  ctx.strokeStyle = colour;
  ctx.lineWidth = 1.5;
  ctx.beginPath();
  ctx.ellipse(v.px(x), v.py(y), Math.max(1, ELLIPSE_SCALE * major * v.scale),
              Math.max(1, ELLIPSE_SCALE * minor * v.scale), -angle, 0, 2 * Math.PI);
  ctx.stroke();
}

function drawRobot(v, x, y, phi, radius, fill, outline, dashed) {
  ctx.beginPath();
  ctx.arc(v.px(x), v.py(y), radius * v.scale, 0, 2 * Math.PI);
  ctx.setLineDash(dashed ? [4, 3] : []);
  if (fill) { ctx.fillStyle = fill; ctx.fill(); }
  ctx.strokeStyle = outline;
  ctx.lineWidth = 2.5;
  ctx.stroke();
  ctx.beginPath();
  ctx.moveTo(v.px(x), v.py(y));
  ctx.lineTo(v.px(x + radius * Math.cos(phi)), v.py(y + radius * Math.sin(phi)));
  ctx.stroke();
  ctx.setLineDash([]);
}

function drawBall(v, x, y, radius, fill, outline) {
  ctx.beginPath();
  ctx.arc(v.px(x), v.py(y), Math.max(3, radius * v.scale), 0, 2 * Math.PI);
  ctx.fillStyle = fill;
  ctx.fill();
  ctx.strokeStyle = outline;
  ctx.lineWidth = 2;
  ctx.stroke();
}

// What the last draw() put on the canvas, per robot: written as JSON into #drawn so that a test
// (headless chromium --dump-dom) can compare it with what was published.
let drawn = [];

function drawState(v) {
  const world = state.sim && state.sim.world;
  const radius = world && world.robot_radius > 0 ? world.robot_radius : ROBOT_RADIUS;
  if (world) {
    world.opponent_x.forEach((x, i) => {
      ctx.fillStyle = "#222222";
      ctx.beginPath();
      ctx.arc(v.px(x), v.py(world.opponent_y[i]), world.opponent_radius[i] * v.scale, 0,
              2 * Math.PI);
      ctx.fill();
    });
    world.robot_id.forEach((id, i) => drawRobot(v, world.robot_x[i], world.robot_y[i],
                                                world.robot_phi[i], radius, null,
                                                ROBOT_COLOURS[id] || "#fff", true));
    drawBall(v, world.ball_x, world.ball_y, world.ball_radius, "rgba(255,140,0,0.35)", "#ffffff");
  }
  for (const robot of state.robots) {
    const colour = ROBOT_COLOURS[robot.id] || "#ffffff";
    const rs = robot.robot_state;
    if (rs) {
      const k = rs.covariance;
      drawEllipse(v, rs.x, rs.y, k[0], k[1], k[4], colour);
      drawRobot(v, rs.x, rs.y, rs.phi, radius, STATUS_COLOURS[rs.status] || "#888", colour, false);
      drawn.push({ id: robot.id, x: rs.x, y: rs.y, phi: rs.phi, status: rs.status,
                   twin_ambiguous: rs.twin_ambiguous, utime: rs.utime, seq: rs.seq });
      ctx.fillStyle = "#000000";
      ctx.font = "bold 12px sans-serif";
      ctx.textAlign = "center";
      ctx.textBaseline = "middle";
      // "3?": the pose may be its symmetric twin through the centre spot (nothing told them apart).
      ctx.fillText(String(robot.id) + (rs.twin_ambiguous ? "?" : ""), v.px(rs.x), v.py(rs.y));
      const lines = robot.vision_lines;
      if (robot.id === selected && lines) {
        // Robot-frame points placed at the estimated pose: a wrong estimate shows at once.
        const c = Math.cos(rs.phi), s = Math.sin(rs.phi);
        ctx.fillStyle = "#ff00ff";
        lines.x.forEach((px, i) => {
          const py = lines.y[i];
          ctx.fillRect(v.px(rs.x + c * px - s * py) - 1.5, v.py(rs.y + s * px + c * py) - 1.5, 3, 3);
        });
      }
    }
    const ball = robot.ball_state;
    if (ball && ball.valid) drawBall(v, ball.x, ball.y, 0.11, "#ff8c00", colour);
  }
  // The team ball as the selected robot's teamcomm sees it.
  const mine = state.robots.find((r) => r.id === selected);
  const team = mine && mine.team_state;
  if (team && team.team_ball_valid) {
    drawBall(v, team.team_ball_x, team.team_ball_y, 0.18, "rgba(255,140,0,0.5)", "#ffff00");
    const k = team.team_ball_covariance;
    drawEllipse(v, team.team_ball_x, team.team_ball_y, k[0], k[1], k[3], "#ffff00");
  }
}

function draw() {
  canvas.width = canvas.clientWidth;
  canvas.height = canvas.clientHeight;
  ctx.fillStyle = "#3a3a3a";
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!field) return;
  const v = view();
  drawField(v);
  drawn = [];
  if (state) drawState(v);
  document.getElementById("drawn").textContent =
      JSON.stringify({ utime: state ? state.utime : null, robots: drawn });
}

function cell(row, text, cls) {
  const td = row.insertCell();
  td.textContent = text;
  if (cls) td.className = cls;
  return td;
}

function processRows(table, processes) {
  for (const p of processes) {
    const row = table.insertRow();
    const stateName = p.stale ? "stale" : (PROCESS_STATES[p.state] || "?");
    cell(row, "  " + p.process);
    cell(row, stateName, p.stale ? "stale" : PROCESS_STATES[p.state]);
    const out = p.channels.filter((c) => c.direction === "out" && c.name !== "SERVICE_STATUS");
    cell(row, out.map((c) => `${c.name} ${c.rate_hz.toFixed(1)} Hz`).join(", "));
    cell(row, out.map((c) => c.latency_p50_ms.toFixed(1)).join("/"));
    cell(row, p.processing_p50_ms.toFixed(2));
    cell(row, String(p.errors_total), p.errors_total > 0 ? "warn" : "");
    row.title = p.last_error || "";
  }
}

function updateTable() {
  const table = document.getElementById("status");
  table.innerHTML = "";
  const head = table.insertRow();
  for (const h of ["process", "state", "outputs", "lat p50 ms", "proc ms", "errors"]) {
    const th = document.createElement("th");
    th.textContent = h;
    head.appendChild(th);
  }
  for (const robot of state.robots) {
    const row = table.insertRow();
    row.className = "robot" + (robot.id === selected ? " selected" : "");
    row.onclick = () => { selected = robot.id; select.value = String(robot.id); draw(); };
    const rs = robot.robot_state;
    const name = cell(row, "");
    const swatch = document.createElement("span");
    swatch.className = "swatch";
    swatch.style.background = ROBOT_COLOURS[robot.id];
    name.append(swatch, ` robot ${robot.id}`);
    const td = cell(row, rs ? STATUS_NAMES[rs.status] || "?" : "no estimate");
    td.colSpan = 5;
    if (rs) {
      const sd = Math.sqrt(Math.max(0, rs.covariance[0] + rs.covariance[4]));
      td.textContent += ` (${rs.x.toFixed(2)}, ${rs.y.toFixed(2)}, ` +
        `${(rs.phi * 180 / Math.PI).toFixed(0)}°) σ ${(100 * sd).toFixed(0)} cm`;
    }
    processRows(table, robot.processes);
  }
  if (state.sim && (state.sim.world || state.sim.processes.length)) {
    const row = table.insertRow();
    row.className = "robot";
    cell(row, "simulator");
    cell(row, state.sim.world ? state.sim.world.scenario : "").colSpan = 5;
    processRows(table, state.sim.processes);
  }
}

function updateSelect() {
  const ids = state.robots.map((r) => String(r.id));
  if ([...select.options].map((o) => o.value).join() === ids.join()) return;
  select.innerHTML = "";
  for (const id of ids) select.add(new Option(`robot ${id}`, id));
  if (!ids.includes(String(selected))) selected = Number(ids[0]);
  select.value = String(selected);
}

function connect() {
  const status = document.getElementById("connection");
  const socket = new WebSocket(`ws://${location.host}/ws`);
  socket.onopen = () => { status.textContent = "live"; status.className = "ok"; };
  socket.onmessage = (event) => {
    state = JSON.parse(event.data);
    if (!state.robots) return;
    window.fieldlineState = state;
    updateSelect();
    updateTable();
    draw();
  };
  socket.onclose = () => {
    status.textContent = "disconnected: retrying";
    status.className = "error";
    setTimeout(connect, 1000);
  };
}

// --- the camera view: the selected robot's frame with the line points the tracker found in it ---

const cameraCanvas = document.getElementById("camera");
const cameraCtx = cameraCanvas.getContext("2d");
const CAMERA_PERIOD_MS = 200;  // the viewer encodes at most 5 frames a second by default

function drawCamera(doc, image) {
  const f = doc.frame;
  cameraCanvas.width = f.width;
  cameraCanvas.height = f.height;
  // A preview (CAMERA_PREVIEW, from another machine than the robot) is a smaller image of the
  // same frame: drawn at the camera's size, where the line points are.
  cameraCtx.drawImage(image, 0, 0, f.width, f.height);
  let marks = 0;
  const lines = doc.lines;
  if (lines) {
    // Each sequence follows one green region's contour: joined, then every point marked.
    cameraCtx.strokeStyle = "rgba(255,0,0,0.8)";
    cameraCtx.lineWidth = 1;
    for (const [start, end] of lines.sequences) {
      cameraCtx.beginPath();
      for (let i = start; i < end; ++i) {
        if (i === start) cameraCtx.moveTo(lines.u[i], lines.v[i]);
        else cameraCtx.lineTo(lines.u[i], lines.v[i]);
      }
      cameraCtx.stroke();
    }
    cameraCtx.fillStyle = "#ff00ff";
    lines.u.forEach((u, i) => { cameraCtx.fillRect(u - 1.5, lines.v[i] - 1.5, 3, 3); ++marks; });
  }
  const ball = doc.ball;
  if (ball && ball.visible) {
    cameraCtx.strokeStyle = "#00ffff";
    cameraCtx.lineWidth = 2;
    cameraCtx.beginPath();
    cameraCtx.arc(ball.u, ball.v, 6, 0, 2 * Math.PI);
    cameraCtx.stroke();
  }
  document.getElementById("camera-caption").textContent =
      `camera of robot ${doc.robot}: frame ${f.frame_number}` +
      (f.stream === "preview" ? ` (preview ${f.image_width}x${f.image_height})` : "") + ", " +
      (lines ? `${lines.num_points} line points` : "no VISION_LINES for this frame") +
      (ball && ball.visible ? ", ball" : "");
  document.getElementById("camera-drawn").textContent = JSON.stringify({
    robot: doc.robot, utime: f.utime, seq: f.seq, stream: f.stream, width: f.width,
    height: f.height,
    image_width: image.naturalWidth, image_height: image.naturalHeight,
    jpeg_bytes: f.jpeg_bytes, lines_utime: lines ? lines.utime : null,
    lines_seq: lines ? lines.seq : null, marks, ball: !!(ball && ball.visible),
  });
}

// Polls /camera.json for the selected robot (asking is what makes the viewer encode its frames).
async function pollCamera() {
  const started = performance.now();
  const robot = selected;
  try {
    const response = await fetch(`/camera.json?robot=${robot}`, { cache: "no-store" });
    const doc = await response.json();
    if (doc.frame && doc.robot === selected) {
      const image = new Image();
      image.src = "data:image/jpeg;base64," + doc.frame.jpeg;
      await image.decode();
      drawCamera(doc, image);
    } else if (!doc.frame) {
      document.getElementById("camera-caption").textContent =
          `camera of robot ${robot}: waiting for a frame`;
    }
  } catch (error) {
    document.getElementById("camera-caption").textContent = `camera: ${error}`;
  }
  setTimeout(pollCamera, Math.max(0, CAMERA_PERIOD_MS - (performance.now() - started)));
}

fetch("/field.json").then((r) => r.json()).then((f) => { field = f; draw(); connect(); });
pollCamera();
window.addEventListener("resize", draw);
