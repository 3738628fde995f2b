// fieldline viewer: a recording's timeline and plots (fieldline-viewer --log, docs/viewer.md
// "Watching a recording"). The viewer plays the recording on its side and pushes the team's
// picture at the playhead over the same WebSocket as a live view (viewer.js draws it); this
// script adds play/pause, speed and a scrubbable timeline (GET /playback.json?...), and plots
// the recording's series (GET /recording.json) with Chart.js (Debian's libjs-chart.js, served at
// /lib/chart.min.js), a cursor at the playhead. On a live view /recording.json is 404 and nothing
// happens.
"use strict";

(function () {
  const PLOT_COLOURS = ["", "#e74c3c", "#3498db", "#9b59b6", "#1abc9c", "#e67e22", "#7f8c8d"];
  const STATUS_LABELS = ["unknown", "searching", "tracking", "odometry only"];
  // One chart per series of /recording.json: its key(s), title and y unit.
  const PLOTS = [
    // Logarithmic where centimetres while tracking and metres while lost share a plot.
    { id: "error", keys: ["error"], title: "position error against the truth", unit: "m",
      log: true },
    { id: "heading", keys: ["heading_error"], title: "heading error against the truth",
      unit: "deg", log: true },
    { id: "sigma", keys: ["sigma"], title: "reported position sigma", unit: "m", log: true },
    { id: "status", keys: ["status"], title: "localization status", unit: "", stepped: true },
    { id: "ball", keys: ["ball_error"], title: "ball error against the truth", unit: "m",
      log: true },
    { id: "rate", keys: ["rate"], title: "ROBOT_STATE rate", unit: "Hz" },
    { id: "latency", keys: ["latency", "lines_latency"], title: "latency (solid: ROBOT_STATE, " +
      "dashed: VISION_LINES)", unit: "ms" },
  ];

  let recording = null;
  let charts = [];
  let playhead = 0;
  let scrubbing = false;

  function control(query) {
    return fetch(`/playback.json?${query}`, { cache: "no-store" }).then((r) => r.json());
  }

  function loadScript(src) {
    return new Promise((resolve, reject) => {
      const script = document.createElement("script");
      script.src = src;
      script.onload = resolve;
      script.onerror = () => reject(new Error(`cannot load ${src}`));
      document.head.appendChild(script);
    });
  }

  function buildTimeline(duration) {
    const bar = document.getElementById("timeline");
    bar.style.display = "flex";
    bar.innerHTML = "";
    const play = document.createElement("button");
    play.id = "play";
    play.textContent = "play";
    play.onclick = () => control(play.textContent === "play" ? "play" : "pause");
    const speed = document.createElement("select");
    speed.id = "speed";
    for (const s of [0.1, 0.25, 0.5, 1, 2, 4, 8]) speed.add(new Option(`${s}x`, String(s)));
    speed.value = "1";
    speed.onchange = () => control(`speed=${speed.value}`);
    const slider = document.createElement("input");
    slider.id = "scrub";
    slider.type = "range";
    slider.min = "0";
    slider.max = String(duration);
    slider.step = "0.05";
    slider.value = "0";
    slider.oninput = () => { scrubbing = true; control(`t=${slider.value}`); };
    slider.onchange = () => { scrubbing = false; };
    const label = document.createElement("span");
    label.id = "time";
    bar.append(play, speed, slider, label);
  }

  // A vertical line at the playhead on every chart.
  const cursor = {
    id: "playhead",
    afterDraw(chart) {
      const x = chart.scales.x.getPixelForValue(playhead);
      if (x < chart.chartArea.left || x > chart.chartArea.right) return;
      const ctx = chart.ctx;
      ctx.save();
      ctx.strokeStyle = "#000000";
      ctx.lineWidth = 1;
      ctx.beginPath();
      ctx.moveTo(x, chart.chartArea.top);
      ctx.lineTo(x, chart.chartArea.bottom);
      ctx.stroke();
      ctx.restore();
    },
  };

  function buildPlots() {
    const box = document.getElementById("plots");
    box.style.display = "block";
    const duration = (recording.end_utime - recording.start_utime) / 1e6;
    const plotted = {};
    for (const plot of PLOTS) {
      const datasets = [];
      for (const robot of recording.robots) {
        plot.keys.forEach((key, k) => {
          const points = robot[key] || [];
          if (!points.length) return;
          datasets.push({
            label: `robot ${robot.id}` + (k > 0 ? " lines" : ""),
            // A logarithmic axis has no place for 0.
            data: points.filter(([, y]) => !plot.log || y > 0).map(([x, y]) => ({ x, y })),
            borderColor: PLOT_COLOURS[robot.id] || "#333333",
            backgroundColor: PLOT_COLOURS[robot.id] || "#333333",
            borderDash: k > 0 ? [4, 3] : [],
            borderWidth: 1.2,
            pointRadius: 0,
            stepped: plot.stepped ? "before" : false,
          });
        });
      }
      plotted[plot.id] = datasets.map((d) => ({ label: d.label, points: d.data.length }));
      if (!datasets.length) continue;
      const canvas = document.createElement("canvas");
      canvas.id = `plot-${plot.id}`;
      canvas.height = 150;
      box.appendChild(canvas);
      const yTicks = plot.id === "status"
        ? { stepSize: 1, callback: (v) => STATUS_LABELS[v] || v } : {};
      charts.push(new Chart(canvas, {
        type: "line",
        data: { datasets },
        plugins: [cursor],
        options: {
          animation: false,
          parsing: false,
          normalized: true,
          responsive: true,
          plugins: {
            title: { display: true, text: plot.title },
            legend: { labels: { boxWidth: 10, font: { size: 10 } } },
            decimation: { enabled: true, algorithm: "min-max" },
          },
          scales: {
            x: { type: "linear", min: 0, max: duration,
                 title: { display: true, text: "time since the recording's start [s]" } },
            y: plot.log
              ? { type: "logarithmic",
                  title: { display: true, text: `[${plot.unit}], log scale` } }
              : { title: { display: !!plot.unit, text: plot.unit ? `[${plot.unit}]` : "" },
                  ticks: yTicks, beginAtZero: true },
          },
          onClick: (event, elements, chart) => {
            // A click on a plot moves the playhead there.
            const t = chart.scales.x.getValueForPixel(event.x);
            if (Number.isFinite(t)) control(`t=${Math.max(0, t).toFixed(2)}`);
          },
        },
      }));
    }
    document.getElementById("plotted").textContent = JSON.stringify(plotted);
  }

  // Follows the playhead of the documents viewer.js receives.
  function follow() {
    const state = window.fieldlineState;
    const p = state && state.playback;
    if (p) {
      const moved = Math.abs(p.t_s - playhead) > 1e-6;
      playhead = p.t_s;
      const slider = document.getElementById("scrub");
      if (slider && !scrubbing) slider.value = String(p.t_s);
      document.getElementById("play").textContent = p.playing ? "pause" : "play";
      document.getElementById("time").textContent =
        `${p.t_s.toFixed(2)} s of ${p.duration_s.toFixed(1)} s` + (p.playing ? ` at ${p.speed}x` : "");
      const status = document.getElementById("connection");
      status.textContent = "recording";
      status.className = "ok";
      if (moved) for (const chart of charts) chart.draw();
    }
    requestAnimationFrame(follow);
  }

  fetch("/recording.json", { cache: "no-store" })
    .then((r) => (r.ok ? r.json() : null))
    .then(async (doc) => {
      if (!doc) return;  // a live view
      recording = doc;
      window.fieldlineRecording = doc;
      // Recordings hold no camera view (fieldline-record --images keeps frames for a replay of
      // region tracking, not for the page).
      document.getElementById("camera").style.display = "none";
      document.getElementById("camera-caption").style.display = "none";
      buildTimeline((doc.end_utime - doc.start_utime) / 1e6);
      await loadScript("/lib/chart.min.js");
      buildPlots();
      follow();
    })
    .catch((error) => {
      document.getElementById("plotted").textContent = JSON.stringify({ load_error: String(error) });
    });
})();
