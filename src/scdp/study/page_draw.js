// The study page's drawing: a motion as it stood t seconds in, over the top view or the camera's frames, and
// each rated motion replayed at the end. Inlined before page.js into one script (scdp.study.app.page_html),
// so it shares page.js's globals (trial, motion, canvas, ctx, images, poster) and runs nothing at load.

function lerpPath(path, t) {  // the path up to t seconds of the motion (one point every trial.point_s s), the last interpolated
  const x = t / trial.point_s, i = Math.min(Math.floor(x), path.length - 1), f = x - i;
  const out = path.slice(0, i + 1);
  if (i + 1 < path.length && f > 0) out.push(path[i].map((v, k) => v + f * (path[i + 1][k] - v)));
  return out;
}
let topMap = null;
function topView() {  // task x is "up" on the screen, task y is "left"; framed on the goals and the start
  const pts = trial.goals.concat([trial.start]);
  const xs = pts.map(p => -p[1]), ys = pts.map(p => -p[0]);
  const pad = 0.2, minx = Math.min(...xs), maxx = Math.max(...xs), miny = Math.min(...ys), maxy = Math.max(...ys);
  const span = Math.max(maxx - minx, maxy - miny) * (1 + 2 * pad) || 1;
  const s = Math.min(canvas.width, canvas.height) / span;
  const cx = (minx + maxx) / 2, cy = (miny + maxy) / 2;
  return (p) => [canvas.width / 2 + (-p[1] - cx) * s, canvas.height / 2 + (-p[0] - cy) * s];
}
function goalPixels() {
  if (trial.view.kind === "camera") { const sx = canvas.width / trial.view.width; return trial.view.goals_px.map(p => [p[0] * sx, p[1] * sx]); }
  return trial.goals.map(topMap);
}
function draw(t) {
  const view = trial.view;
  const shownWorld = motion ? lerpPath(motion.path, t) : [trial.start];
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  let pathPx;
  if (view.kind === "camera") {
    const sx = canvas.width / view.width;
    const frame = motion ? Math.min(motion.frames.length - 1, Math.floor(t * view.fps + 1e-6)) : -1;
    let img = null;
    for (let j = frame; j >= 0 && !img; j--) { const im = images[motion.frames[j]]; if (im && im.complete && im.naturalWidth) img = im; }
    if (!img && poster && poster.complete && poster.naturalWidth) img = poster;  // the scene before Start
    ctx.save();
    if (view.flip) { ctx.translate(canvas.width, 0); ctx.scale(-1, 1); }
    if (img) ctx.drawImage(img, 0, 0, canvas.width, canvas.height);
    else { ctx.fillStyle = "#ddd"; ctx.fillRect(0, 0, canvas.width, canvas.height); }
    ctx.restore();
    pathPx = motion ? lerpPath(motion.path_px, t).map(p => [p[0] * sx, p[1] * sx]) : [];
  } else {
    ctx.fillStyle = "#fff"; ctx.fillRect(0, 0, canvas.width, canvas.height);
    pathPx = shownWorld.map(topMap);
  }
  const gp = goalPixels(), r = Math.max(12, canvas.width / 32);
  gp.forEach((p, k) => {  // the goal's colour in a dark outline, its name's initial inside (not colour alone)
    const picked = window.study.picked === k, hex = trial.colours[k].hex;
    ctx.beginPath(); ctx.arc(p[0], p[1], r, 0, 2 * Math.PI);
    if (view.kind !== "camera") { ctx.fillStyle = hex; ctx.fill(); }  // over a camera frame: a ring, the block inside
    ctx.lineWidth = 3; ctx.strokeStyle = "#111"; ctx.stroke();
    if (view.kind === "camera") { ctx.lineWidth = 2; ctx.strokeStyle = hex; ctx.beginPath(); ctx.arc(p[0], p[1], r - 2.5, 0, 2 * Math.PI); ctx.stroke(); }
    if (picked) { ctx.lineWidth = 3; ctx.strokeStyle = "#111"; ctx.beginPath(); ctx.arc(p[0], p[1], r + 5, 0, 2 * Math.PI); ctx.stroke(); }
    ctx.font = `bold ${Math.round(r * 1.1)}px system-ui, sans-serif`; ctx.textAlign = "center"; ctx.textBaseline = "middle";
    ctx.lineWidth = 3; ctx.strokeStyle = "#111"; ctx.fillStyle = "#fff";
    const letter = trial.colours[k].name[0].toUpperCase();
    ctx.strokeText(letter, p[0], p[1] + 1); ctx.fillText(letter, p[0], p[1] + 1);
  });
  if (pathPx.length) {
    ctx.beginPath(); ctx.arc(pathPx[0][0], pathPx[0][1], 6, 0, 2 * Math.PI); ctx.lineWidth = 2; ctx.strokeStyle = "#777"; ctx.stroke();
    ctx.lineWidth = 4; ctx.strokeStyle = "#37474f"; ctx.lineJoin = "round"; ctx.beginPath();  // a neutral slate: no goal's hue
    pathPx.forEach((p, i) => i ? ctx.lineTo(p[0], p[1]) : ctx.moveTo(p[0], p[1])); ctx.stroke();
    const head = pathPx[pathPx.length - 1];
    ctx.fillStyle = "#222"; ctx.beginPath(); ctx.arc(head[0], head[1], 7, 0, 2 * Math.PI); ctx.fill();
  }
  Object.assign(window.study, { t, shown: shownWorld });
}

// ----- the end-of-study ratings: each motion replayed -----
const ratingImages = {};
function renderItem(cv, item, t) {  // the item's motion as it stood t seconds in
  const saved = [canvas, ctx, trial, motion, images, poster, topMap];
  canvas = cv; ctx = cv.getContext("2d"); trial = item.trial; motion = item.motion; images = ratingImages; poster = null;
  if (trial.view.kind === "camera") {
    for (const f of motion.frames) if (!images[f]) { const im = new Image(); im.src = "/frames/" + f; images[f] = im; }
  } else topMap = topView();
  draw(t);
  [canvas, ctx, trial, motion, images, poster, topMap] = saved;
}
function replay(cv, item) {  // each rated motion plays again and again at its own speed, a second's pause at its end
  const length = (item.motion.path.length - 1) * item.trial.point_s, began = performance.now();
  const tick = (now) => {
    if (window.study.screen !== "ratings") return;
    renderItem(cv, item, Math.min(length, ((now - began) / 1000) % (length + 1)));
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
}
