// realcam live lens lab: the page over the JSON API (see README, "realcam serve").
"use strict";

const $ = (id) => document.getElementById(id);
// Settings the page edits as one number each, and as a pair (inputs NAME_x, NAME_y).
const NUMBERS = ["focus_distance", "f_number", "aperture", "film_diagonal", "blades",
  "blade_rotation", "blade_curvature", "width", "height", "exposure"];
const PAIRS = ["shift", "tilt"];
let state = null;
// Answers to concurrent requests may arrive in any order: keep only the newest state (the
// server's `revision` grows with every publication) and the newest image.
let requestedGeneration = -1;
let displayedGeneration = -1;
let lensGeneration = null;

async function api(path, body) {
  const options = body === undefined ? {} : {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify(body),
  };
  const response = await fetch(path, options);
  const data = await response.json();
  if (!response.ok) throw new Error(data.error || response.statusText);
  return data;
}

function message(text) { $("message").textContent = text || ""; }

// Shows a state; the control being edited keeps what is typed in it, unless `reset` (the
// server refused it: it shows what the server has).
function show(newState, reset = false) {
  if (state && newState.revision < state.revision) return;
  state = newState;
  refreshImage(state.generation);
  // Four significant digits are enough to read a measure (the state keeps every digit); whole
  // numbers (pixels, blades) are shown as they are.
  const readable = (value) => Number.isInteger(value) ? value : Number(value.toPrecision(4));
  const shown = (input, value) => {
    if (reset || document.activeElement !== input) input.value = typeof value === "number" ? readable(value) : value ?? "";
  };
  for (const name of NUMBERS) shown($(name), state[name]);
  for (const name of PAIRS) {
    const [x, y] = state[name] ?? [null, null];
    shown($(name + "_x"), x);
    shown($(name + "_y"), y);
  }
  for (const name of ["focus_mode", "dispersion", "filter", "flare"]) {
    if (state[name]) $(name).value = state[name];
  }
  if (state.wavelengths) $("wavelengths").value = String(state.wavelengths);
  $("coating").value = state.coating ?? "";
  // The zoom ring: one entry per position of a zoom lens, hidden for a fixed one.
  const positions = (state.lens_info && state.lens_info.zoom_positions) || [];
  $("zoom_ring").hidden = positions.length === 0;
  const ring = $("zoom_position");
  const entries = [["", "as written"]].concat(positions.map((p) =>
    [String(p.position), p.focal_length_mm ? `${p.position}: ${readable(p.focal_length_mm)} mm` : String(p.position)]));
  if (ring.options.length !== entries.length || [...ring.options].some((o, i) => o.value !== entries[i][0] || o.text !== entries[i][1])) {
    ring.replaceChildren(...entries.map(([value, text]) => new Option(text, value)));
  }
  ring.value = state.zoom_position ? String(state.zoom_position) : "";
  if (reset || document.activeElement !== $("spp_target_input")) $("spp_target_input").value = state.spp;
  if ($("lens").value !== state.lens) $("lens").value = state.lens;
  $("spp").textContent = state.spp_done;
  $("spp-target").textContent = state.spp_target;
  $("command").textContent = state.command;
  if (state.error) message(state.error);
  $("warning").textContent = state.warning || "";
  const key = JSON.stringify([state.lens, state.focus_distance, state.film_distance, state.f_number,
    state.aperture, state.film_diagonal, state.focus_mode, state.blades, state.blade_rotation,
    state.blade_curvature, state.shift, state.tilt, state.dispersion]);
  if (key !== lensGeneration) { lensGeneration = key; refreshLens(); }
}

async function refreshLens() {
  try {
    const [svg, info] = await Promise.all([
      fetch("/api/lens.svg").then((r) => r.text()),
      api("/api/lens.json"),
    ]);
    $("diagram").innerHTML = svg;
    const number = (v, digits = 2) => (typeof v === "number" ? v.toFixed(digits) : "—");
    const rows = [
      ["lens", info.name],
      ["focal length", number(info.focal_length_mm) + " mm"],
      ["f-number", "f/" + number(info.f_number)],
      ["working f-number", "f/" + number(info.working_f_number)],
      ["stop diameter", number(info.stop_diameter_mm) + " mm"],
      ["back focal length", number(info.back_focal_length_mm) + " mm"],
      ["film distance", number(info.film_distance_mm, 3) + " mm"],
      ["focus distance", info.focus_distance_m == null ? "—" : number(info.focus_distance_m, 3) + " m"],
      ["closest focus", number(info.closest_focus_m, 3) + " m"],
      ["field of view", typeof info.field_of_view_deg === "number" ? number(info.field_of_view_deg, 1) + "°"
        : info.image_circle ? `corners outside the image circle (⌀ ${number(info.image_circle.diameter_mm, 1)} mm, ${number(info.image_circle.field_of_view_deg, 1)}°)` : "—"],
      ["entrance pupil", info.entrance_pupil ? number(info.entrance_pupil.diameter_mm ?? info.entrance_pupil.diameter) + " mm" : "—"],
      ["total track", number(info.total_track_mm) + " mm"],
      ["diaphragm", info.diaphragm ? diaphragmText(info.diaphragm) : "round"],
    ];
    const colour = info.chromatic;
    if (colour) {
      // A figure the lens report could not compute (null: no chief ray reaches that height,
      // which lies outside the image circle) is n/a, never a zero.
      const micrometres = (mm) => (mm === null || mm === undefined ? "n/a" : number(mm * 1000, 1) + " µm");
      rows.push(["axial colour (F−C)", micrometres(colour.axial_colour_mm)]);
      rows.push(["lateral colour (F−C)", micrometres(colour.lateral_colour_mm) + " at "
        + number(colour.lateral_colour_film_height_mm, 1) + " mm"]);
      const glasses = [...new Set(colour.glasses.filter((g) => g.glass).map((g) => g.glass))];
      rows.push(["glasses", glasses.length ? glasses.join(", ") : "none named"]);
    }
    $("first-order").innerHTML = rows
      .map(([k, v]) => `<tr><td>${k}</td><td>${String(v).replace(/</g, "&lt;")}</td></tr>`).join("");
  } catch (e) { message(e.message); }
}

function diaphragmText(d) {
  const fraction = typeof d.open_fraction === "number" ? ` (${(d.open_fraction * 100).toFixed(1)} % open)` : "";
  return (d.shape || "shaped") + fraction;
}

// Sends a change and shows its answer. A refused change leaves the server on the settings it
// had, so the controls go back to them (the published state), or a refused lens would stay
// picked while the image is still the old lens's.
async function change(path, body) {
  message("");
  try { show(await api(path, body)); } catch (e) {
    message(e.message);
    try { show(await api("/api/state"), true); } catch (_) { /* the next event tries again */ }
  }
}

function refreshImage(generation) {
  if (generation <= requestedGeneration || generation === 0) return;
  requestedGeneration = generation;
  const next = new Image();
  next.onload = () => {
    if (generation <= displayedGeneration) return;
    displayedGeneration = generation;
    $("image").src = next.src;
  };
  next.src = "/api/image.png?g=" + generation;
}

async function refreshStats() {
  try {
    const [stats, newState] = await Promise.all([api("/api/stats"), api("/api/state")]);
    $("rate").textContent = (stats.samples_per_second / 1e6).toFixed(2);
    show(newState);
  } catch (e) { /* the next event tries again */ }
}

async function start() {
  const lenses = await api("/api/lenses");
  for (const lens of lenses.lenses) {
    const option = document.createElement("option");
    option.value = lens.name;
    option.textContent = lens.origin === "bundled" ? lens.name : `${lens.name} (${lens.origin})`;
    $("lens").append(option);
  }
  show(await api("/api/state"));

  $("message").addEventListener("click", () => message(""));
  $("lens").addEventListener("change", (e) => change("/api/settings", { lens: e.target.value }));
  for (const name of NUMBERS) {
    $(name).addEventListener("change", (e) => {
      const v = e.target.value.trim();
      change("/api/settings", { [name]: v === "" ? null : Number(v) });
    });
  }
  for (const name of PAIRS) {
    const changed = () => {
      const [x, y] = [$(name + "_x").value.trim(), $(name + "_y").value.trim()];
      change("/api/settings", { [name]: x === "" && y === "" ? null : [Number(x || 0), Number(y || 0)] });
    };
    $(name + "_x").addEventListener("change", changed);
    $(name + "_y").addEventListener("change", changed);
  }
  for (const name of ["focus_mode", "dispersion", "filter", "flare"]) {
    $(name).addEventListener("change", (e) => change("/api/settings", { [name]: e.target.value }));
  }
  $("wavelengths").addEventListener("change", (e) => change("/api/settings", { wavelengths: Number(e.target.value) }));
  $("coating").addEventListener("change", (e) => change("/api/settings", { coating: e.target.value || null }));
  $("zoom_position").addEventListener("change", (e) => change("/api/settings", { zoom_position: e.target.value ? Number(e.target.value) : null }));
  $("spp_target_input").addEventListener("change", (e) => change("/api/settings", { spp: Number(e.target.value) }));
  $("image").addEventListener("click", (e) => {
    const box = e.target.getBoundingClientRect();
    const [w, h] = [state.width, state.height];
    // The picture is letterboxed inside the element (object-fit: contain).
    const scale = Math.min(box.width / w, box.height / h);
    const x = (e.clientX - box.left - (box.width - w * scale) / 2) / scale;
    const y = (e.clientY - box.top - (box.height - h * scale) / 2) / scale;
    change("/api/focus", { x, y });
  });
  $("save").addEventListener("click", async () => {
    try {
      const saved = await api("/api/save", {});
      message("");
      $("command").textContent = `wrote ${saved.out} and ${saved.exr} (${saved.spp} spp)\n${saved.command}`;
    } catch (e) { message(e.message); }
  });

  const events = new EventSource("/api/events");
  const announced = (e) => {
    refreshImage(JSON.parse(e.data).generation);
    refreshStats();
  };
  events.addEventListener("image", announced);
  events.addEventListener("state", announced);
}

start().catch((e) => message(e.message));
