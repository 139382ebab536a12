// The study page's behaviour: screens, the motion's playback at the server's pace, picks, and what a
// person sees exposed read-only as window.study. scdp.study.app inlines it into page.html, so the
// participant still receives one self-contained document.
"use strict";
const params = new URLSearchParams(location.search);
const PID = params.get("pid") || params.get("PROLIFIC_PID") || "";
const PID_OK = /^[A-Za-z0-9_.-]{1,64}$/;
const STUDY_ID = params.get("STUDY_ID") || params.get("study_id") || "";
const SESSION_ID = params.get("SESSION_ID") || params.get("session_id") || "";
const PLATFORM_OK = /^[A-Za-z0-9_.-]{0,64}$/;
const POLL_MS = 100, RETRY_MS = 1000;
const HINTS = { ready: "Press Start when you are ready: the motion plays once.",
                playing: "Click the goal you think the robot is heading to.",
                resumed: "The motion went on while the page reloaded. Click the goal you think the robot is heading to.",
                ended: "The motion has ended: confirm your answer (you can still change it).",
                sending: "Saving your answer\u2026" };
// what a person sees, for the simulated participant and the tests: read-only outside this script
window.study = { screen: "loading", index: null, kind: null, started: false, playing: false, t: 0, done: false,
                 goals: [], shown: [], picked: null, confidence: null, offline: false, note: null, feedback: null,
                 questions: [], items: [], away: 0, calls: 0, refused: null };
const $ = (id) => document.getElementById(id);
let trial = null, motion = null, start = null, images = {}, poster = null, pollTimer = null, queue = Promise.resolve();
let canvas = null, ctx = null;

function show(name) {
  for (const s of document.querySelectorAll("main > section")) s.hidden = s.id !== "screen-" + name;
  window.study.screen = name;
}
function fail(text) {
  if (text.startsWith("session:")) {  // another browser, or the slot's time ran out: a page of its own
    $("lost-pid").textContent = PID; show("lost"); return;
  }
  $("error-text").textContent = text; show("error");
}
function hint(key) { $("trial-hint").textContent = HINTS[key]; window.study.hint = key; }
const wait = (ms) => new Promise((r) => setTimeout(r, ms));

// Every call retries while the server cannot be reached (or is restarting), showing so; a refusal
// (a 4xx with the one-line error) is returned to the caller.
async function call(route, body) {
  window.study.calls += 1;  // in flight: the simulated participant waits for none before it looks again
  try { return await callUntilAnswered(route, body); } finally { window.study.calls -= 1; }
}
async function callUntilAnswered(route, body) {
  for (;;) {
    try {
      const r = await fetch(route, { method: "POST", headers: { "Content-Type": "application/json" },
                                     body: JSON.stringify(body), credentials: "same-origin" });
      if (r.status < 500) {
        const data = await r.json().catch(() => ({ error: "server: the answer was not JSON" }));
        $("offline").hidden = true; window.study.offline = false;
        return { status: r.status, data };
      }
    } catch (e) { /* the network: retry below */ }
    $("offline").hidden = false; window.study.offline = true;
    await wait(RETRY_MS);
  }
}

function back(state, nextId) {  // the code, and (with a platform URL) a button back to the platform: the page
  // stays until the participant leaves (the debrief and its withdrawal instructions with it), never on a timer
  const button = $(nextId.replace("-next", "-return"));
  button.hidden = !state.redirect;
  if (!state.redirect) return;
  $(nextId).textContent = "Copy it, then return to the study platform when you are ready.";
  button.onclick = () => location.assign(state.redirect);
}
const ENDS = { declined: ["You chose not to take part", "Thank you. Nothing of yours was stored. Your code is:"],
               screened: ["Thank you", "The answers to the questions about the instructions were not right twice, " +
                                       "so the study ends here. You will be paid for your time. Your code is:"] };
function enter(state) {
  clearTimeout(pollTimer); pollTimer = null;
  window.study.playing = false;
  if (state.screen === "consent") { show("consent"); return; }
  if (state.screen === "instructions") { instructions(state); return; }
  if (state.screen === "ratings") { ratings(state); return; }
  if (state.screen === "done") {
    $("done-code").textContent = state.code; $("debrief").hidden = false; show("done"); back(state, "done-next"); return;
  }
  if (ENDS[state.screen]) {
    $("end-title").textContent = ENDS[state.screen][0]; $("end-text").textContent = ENDS[state.screen][1];
    $("end-code").textContent = state.code; show("end"); window.study.screen = state.screen;  // declined, screened
    back(state, "end-next"); return;
  }
  trial = state.trial; motion = null; start = null; confidenceLabels = state.confidence;
  beginTrial(state);
}
let confidenceLabels = [];

// ----- the instructions and their comprehension check -----
function instructions(state) {
  const box = $("questions"); box.innerHTML = "";
  window.study.questions = state.questions;
  state.questions.forEach((q, i) => {
    const d = document.createElement("div"); d.className = "question";
    d.appendChild(Object.assign(document.createElement("b"), { textContent: `${i + 1}. ${q.question}` }));
    q.options.forEach((o, k) => {
      const l = document.createElement("label");
      l.innerHTML = `<input type="radio" name="q${i}" value="${k}" id="q${i}-${k}"> `;
      l.appendChild(document.createTextNode(o)); d.appendChild(l);
    });
    box.appendChild(d);
  });
  box.onchange = () => { $("instructions-go").disabled = state.questions.some((_, i) => !document.querySelector(`input[name=q${i}]:checked`)); };
  $("instructions-go").disabled = true;
  if (state.retry) {
    $("comprehension-retry").hidden = false;
    $("comprehension-retry").textContent = "Some answers were not right. Please read the instructions again and answer " +
      `once more (${state.attempts_left} attempt${state.attempts_left === 1 ? "" : "s"} left).`;
  }
  show("instructions");
}
$("instructions-go").onclick = async () => {
  $("instructions-go").disabled = true;
  const answers = window.study.questions.map((_, i) => +document.querySelector(`input[name=q${i}]:checked`).value);
  const { status, data } = await call("/api/comprehension", { pid: PID, answers });
  if (status !== 200) { fail(data.error || "the server refused"); return; }
  if (data.screen === "instructions") data.retry = true;
  enter(data);
};

async function refresh() {
  const { status, data } = await call("/api/state", { pid: PID });
  if (status !== 200) { fail(data.error || "the server refused"); return; }
  enter(data);
}

// ----- drawing (page_draw.js) -----
canvas = $("stage"); ctx = canvas.getContext("2d");

// ----- a trial -----
function beginTrial(state) {
  show("trial");
  const main = trial.n_trials - 1, practice = trial.kind === "practice";
  $("trial-title").textContent = practice ? "Practice" : `Trial ${trial.index} of ${main}`;
  $("trial-tag").hidden = !practice;
  storedPick = state.picked ?? null; $("pick-refused").hidden = true;
  $("confirm").disabled = true; $("confirm").hidden = true; $("confirm").textContent = "Confirm";
  $("note").hidden = true; $("confidence-box").hidden = true;
  const scale = $("confidence"); scale.innerHTML = "";
  confidenceLabels.forEach((name, k) => {
    const l = document.createElement("label");
    l.innerHTML = `<input type="radio" name="confidence" id="confidence-${k + 1}" value="${k + 1}">`;
    l.appendChild(document.createTextNode(name)); scale.appendChild(l);
  });
  scale.onchange = () => { window.study.confidence = +document.querySelector("input[name=confidence]:checked").value; ready(); };
  const box = $("goals"); box.innerHTML = "";
  trial.colours.forEach((c, k) => {
    const b = document.createElement("button");
    b.className = "goal"; b.id = "goal-" + k; b.dataset.goal = k;
    b.innerHTML = `<span class="dot" style="background:${c.hex}"></span>${c.name}`;
    b.disabled = true;  // enabled when the motion plays
    b.onclick = () => pick(k); box.appendChild(b);
  });
  Object.assign(window.study, { index: trial.index, kind: trial.kind, started: false, playing: false, t: 0, done: false,
                                goals: trial.goals, colours: trial.colours.map(c => c.name), shown: [], picked: null,
                                confidence: null, note: null, refused: null });
  const w = Math.min(640, document.querySelector("main").clientWidth);
  canvas.width = w;
  canvas.height = trial.view.kind === "camera" ? Math.round(w * trial.view.height / trial.view.width) : Math.round(w * 0.75);
  images = {}; poster = null;
  if (trial.view.kind === "camera") { poster = new Image(); poster.onload = () => { if (!window.study.playing) draw(0); };
                                      poster.src = "/frames/" + trial.view.poster; }
  else topMap = topView();
  draw(0);
  if (state.playing) {  // a reload while the motion played: it goes on from where the server's clock is
    $("start").hidden = true; markPicked(state.picked); hint("resumed"); startMotion();
  } else { $("start").hidden = false; $("start").disabled = false; hint("ready"); }
}
$("start").onclick = () => { $("start").disabled = true; $("start").hidden = true; hint("playing"); startMotion(); };

function absorb(m) {  // a /api/motion answer: more of the path and frames
  motion = m;
  if (m.frames) for (const f of m.frames) if (!images[f]) { const im = new Image(); im.src = "/frames/" + f; images[f] = im; }
}
async function fetchMotion() {
  const index = trial.index;
  const { status, data } = await call("/api/motion", { pid: PID, trial: index });
  if (!trial || trial.index !== index) return null;
  if (status !== 200) { if (status === 409) refresh(); else fail(data.error || "the server refused"); return null; }
  absorb(data);
  return data;
}
async function startMotion() {
  window.study.started = true;
  const first = await fetchMotion();
  if (!first) return;
  start = performance.now() - first.t * 1000;  // the server's clock: a reload goes on where it is
  window.study.playing = true;
  for (const b of document.querySelectorAll(".goal")) b.disabled = false;
  // polled until the server's clock has passed the end (ended), for every trial alike: an instructed check's
  // note comes with it, so no trial's answers arrive on another schedule than the others'
  const poll = async () => { if (motion && !motion.ended) { await fetchMotion(); pollTimer = setTimeout(poll, POLL_MS); } };
  pollTimer = setTimeout(poll, POLL_MS);
  const tick = (now) => {
    if (!trial || !window.study.playing) return;
    const t = shownSeconds(now);
    draw(t);
    if (!(motion.done && motion.ended && t >= servedSeconds())) requestAnimationFrame(tick);
    else { window.study.done = true; hint("ended"); ended(); }
  };
  requestAnimationFrame(tick);
}
function ended() {  // the motion is over: the note (if any), how sure, Confirm
  if (motion && motion.note) { $("note").textContent = motion.note; $("note").hidden = false; window.study.note = motion.note; }
  $("confidence-box").hidden = false; $("confirm").hidden = false; ready();
}
function ready() { $("confirm").disabled = !(window.study.done && window.study.picked !== null && window.study.confidence); }
function servedSeconds() { return motion ? (motion.path.length - 1) * trial.point_s : 0; }  // what the page holds
function shownSeconds(now) {  // the page's clock, never past what the server has sent
  return Math.min(Math.max(0, (now - start) / 1000), servedSeconds());
}
function markPicked(k) {
  window.study.picked = k;
  for (const b of document.querySelectorAll(".goal")) b.classList.toggle("picked", k !== null && +b.dataset.goal === k);
}
let storedPick = null;  // the trial's last pick the server took: it stands when a later one is refused
function refused(index, error) {  // a pick not taken: the page stays usable, shows the pick that stands and says why
  if (!trial || trial.index !== index) return;
  if (error.startsWith("session:")) { fail(error); return; }
  markPicked(storedPick);
  window.study.refused = error;
  $("pick-refused").textContent = `That click was not saved (${error.replace(/^[\w.]+: /, "")}). ` +
    (storedPick === null ? "Click a goal again." : "Your earlier choice stands; click again to change it.");
  $("pick-refused").hidden = false;
  ready(); if (window.study.done) draw(servedSeconds());
}
function pick(k) {
  if (!window.study.playing || !trial) return;
  // the motion's time at the click (never past what the server sent), rounded down to the millisecond (past a
  // microsecond's float noise, so that 0.7499999 s is 0.750; the server tolerates a millisecond)
  const t = Math.floor(shownSeconds(performance.now()) * 1e3 + 1e-3) / 1e3, index = trial.index;
  markPicked(k); $("pick-refused").hidden = true; window.study.refused = null;
  queue = queue.then(() => call("/api/pick", { pid: PID, trial: index, goal: k, t })).then(({ status, data }) => {
    if (status === 200) { if (trial && trial.index === index) storedPick = data.picked; }
    else refused(index, data.error || "the server refused the pick");  // 429: over the cap or too fast
  });
  if (window.study.done) { ready(); draw(servedSeconds()); }
}
canvas.addEventListener("click", (ev) => {
  if (!trial || !window.study.playing) return;
  const rect = canvas.getBoundingClientRect(), sx = canvas.width / rect.width;
  const x = (ev.clientX - rect.left) * sx, y = (ev.clientY - rect.top) * sx;
  const gp = goalPixels(), d = gp.map(p => Math.hypot(p[0] - x, p[1] - y)), k = d.indexOf(Math.min(...d));
  if (d[k] < Math.max(30, canvas.width / 12)) pick(k);
});
$("confirm").onclick = async () => {
  if ($("confirm").disabled || window.study.picked === null || !window.study.confidence) return;
  $("confirm").disabled = true; hint("sending");
  for (const b of document.querySelectorAll(".goal")) b.disabled = true;
  await queue;  // every pick is stored before the answer
  const { status, data } = await call("/api/response", { pid: PID, trial: trial.index,
                                                          confidence: window.study.confidence });
  window.study.playing = false;
  if (status === 200 && data.feedback) feedback(data);
  else if (status === 200) enter(data);
  else if (status === 409) refresh();
  else fail(data.error || "the server refused the answer");
};
$("consent-box").onchange = (e) => { $("consent-go").disabled = !e.target.checked; };
$("consent-go").onclick = async () => {
  $("consent-go").disabled = true;
  const { status, data } = await call("/api/consent", { pid: PID, study_id: STUDY_ID, session_id: SESSION_ID });
  if (status === 200) enter(data); else fail(data.error);
};
$("consent-decline").onclick = async () => {
  const { status, data } = await call("/api/decline", { pid: PID });
  if (status === 200) enter(data); else fail(data.error);
};

// ----- the practice's feedback -----
let afterFeedback = null;
function feedback(state) {
  afterFeedback = state; window.study.feedback = state.feedback;
  $("feedback-title").textContent = state.feedback.correct ? "Correct!" : "Not quite";
  $("feedback-text").textContent = `The robot was heading to the ${state.feedback.colour} goal.`;
  show("feedback");
}
$("feedback-go").onclick = () => { window.study.feedback = null; enter(afterFeedback); };

// ----- leaving the page while a motion plays (counted by the server) -----
function away(event) {
  if (!trial || !window.study.playing || window.study.screen !== "trial") return;
  window.study.away += 1;
  const index = trial.index;
  queue = queue.then(() => call("/api/focus", { pid: PID, trial: index, event }));
}
document.addEventListener("visibilitychange", () => { if (document.hidden) away("hidden"); });
window.addEventListener("blur", () => away("blur"));

// ----- the end-of-study ratings (page_draw.js replays each motion) -----
function ratings(state) {
  const box = $("items"); box.innerHTML = "";
  window.study.items = state.items; window.study.picked = null;
  const names = Object.keys(state.statements);
  state.items.forEach((item, i) => {
    const d = document.createElement("div"); d.className = "item";
    d.appendChild(Object.assign(document.createElement("b"), { textContent: `Motion ${i + 1}` }));
    const cv = document.createElement("canvas"); cv.width = 360;
    cv.height = item.trial.view.kind === "camera" ? Math.round(360 * item.trial.view.height / item.trial.view.width) : 270;
    d.appendChild(cv);
    for (const name of names) {
      d.appendChild(Object.assign(document.createElement("p"), { textContent: state.statements[name] }));
      const scale = document.createElement("div"); scale.className = "scale";
      for (let v = 1; v <= state.scale; v++) {
        const l = document.createElement("label");
        l.innerHTML = `<input type="radio" name="${name}-${item.item}" id="${name}-${i}-${v}" value="${v}">${v}`;
        scale.appendChild(l);
      }
      d.appendChild(scale);
    }
    box.appendChild(d); replay(cv, item);
  });
  const answers = () => state.items.map(it => Object.fromEntries([["item", it.item], ...names.map(n => {
    const c = document.querySelector(`input[name=${n}-${it.item}]:checked`); return [n, c ? +c.value : null]; })]));
  box.onchange = () => { $("ratings-go").disabled = answers().some(a => names.some(n => a[n] === null)); };
  $("ratings-go").disabled = true;
  $("ratings-go").onclick = async () => {
    $("ratings-go").disabled = true;
    const { status, data } = await call("/api/ratings", { pid: PID, ratings: answers() });
    if (status === 200) enter(data); else fail(data.error || "the server refused the ratings");
  };
  show("ratings");
}

// Back would leave the study: keep the participant here, saying why
history.pushState({ study: true }, "", location.href);
window.addEventListener("popstate", () => { history.pushState({ study: true }, "", location.href); $("no-back").hidden = false; });

if (!PID) fail("This link has no participant ID. Please go back to the study platform and open the study from the link it gave you.");
else if (!PID_OK.test(PID) || !PLATFORM_OK.test(STUDY_ID) || !PLATFORM_OK.test(SESSION_ID)) fail("The participant ID in this link cannot be used here. Please go back to the study platform and open the study from the link it gave you.");
else refresh();
