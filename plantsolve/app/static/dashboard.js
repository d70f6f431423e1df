// plantsolve dashboard: follows the job events (Server-Sent Events) and falls back to polling.
// The pages are rendered on the server; on a status change this script fetches the changed part
// again (/dashboard/rows, /dashboard/jobs/{id}/detail) and swaps it in, so there is one renderer.
(function () {
  "use strict";
  var FINISHED = ["succeeded", "failed", "cancelled"];
  var POLL_MS = 2000;

  function liveState(text, kind) {
    var el = document.getElementById("live-state");
    if (!el) return;
    el.textContent = "live updates: " + text;
    el.className = "live-state " + (kind || "");
  }

  // the same words as dashboard_views.progress_text
  function progressText(status, fraction) {
    if (status === "queued") return "waiting";
    if (status === "running") return fraction >= 1 ? "storing result" : Math.round(100 * fraction) + "%";
    return status === "succeeded" ? "done" : status;
  }

  function paint(scope, job) {
    var bar = scope.querySelector(".bar > span");
    var fraction = job.status === "succeeded" ? 1 : job.progress.fraction;
    if (bar) bar.style.width = (100 * fraction).toFixed(1) + "%";
    var fields = { progress: progressText(job.status, job.progress.fraction), message: job.progress.message,
                   summary: job.summary, status: job.status };
    Object.keys(fields).forEach(function (name) {
      var el = scope.querySelector('[data-field="' + name + '"]');
      if (el && fields[name] !== undefined) el.textContent = fields[name];
    });
  }

  function fetchText(url) {
    return fetch(url, { credentials: "same-origin", headers: { Accept: "text/html, application/json" } })
      .then(function (response) {
        if (!response.ok) throw new Error(url + ": " + response.status);
        return response.text();
      });
  }

  // Opens the stream; on any error it is closed and onFail starts polling instead.
  function stream(url, onJob, onEnd, onFail, onOpen) {
    if (!window.EventSource) { onFail(); return; }
    var source = new EventSource(url);
    source.addEventListener("open", function () {
      document.body.dataset.transport = "events";
      liveState("streaming", "live");
      if (onOpen) onOpen();
    });
    source.addEventListener("job", function (event) { onJob(JSON.parse(event.data)); });
    source.addEventListener("end", function (event) {
      source.close();
      if (onEnd) onEnd(JSON.parse(event.data || "{}"));
    });
    source.onerror = function () { source.close(); onFail(); };
  }

  function every(ms, task) {
    document.body.dataset.transport = "polling";
    var timer = setInterval(function () { if (!document.hidden) task(); }, ms);
    return function () { clearInterval(timer); };
  }

  function followJob(id) {
    var detail = document.getElementById("job-detail");
    var shown = function () { return detail.querySelector("section").dataset.status; };
    var pending = false;
    var again = false;  // a change arrived while a render was on its way: render once more after it
    var stopPolling = null;

    function rerender() {  // the status changed: the server renders report, plots, downloads
      if (pending) { again = true; return; }
      pending = true;
      fetchText("/dashboard/jobs/" + id + "/detail").then(function (html) {
        detail.innerHTML = html;
        return 0;
      }, function () { return POLL_MS; }).then(function (retry) {
        pending = false;
        if (again || retry) {
          again = false;
          setTimeout(rerender, retry);
        } else if (FINISHED.indexOf(shown()) >= 0) {
          liveState("finished", "");
          if (stopPolling) stopPolling();
        }
      });
    }
    function onJob(job) {
      if (job.status !== shown()) rerender();
      else paint(detail, job);
    }
    function poll() {
      liveState("polling every " + POLL_MS / 1000 + " s", "polling");
      var check = function () {
        fetchText("/v1/jobs/" + id).then(function (text) { onJob(JSON.parse(text)); }).catch(function () {});
      };
      stopPolling = every(POLL_MS, check);
      check();
    }
    if (FINISHED.indexOf(shown()) >= 0) { liveState("finished", ""); return; }
    stream("/v1/jobs/" + id + "/events", onJob, function (end) {
      if (end.status && end.status !== shown()) rerender();
    }, poll);
  }

  function followList() {
    var live = document.getElementById("jobs-live");
    var rows = document.body.dataset.rows;
    var firstPage = document.body.dataset.firstPage === "true";
    var timer = null;
    var sent = 0;  // reloads started; an answer older than the newest shown is dropped

    function reload() {
      var mine = ++sent;
      return fetchText(rows).then(function (html) {
        if (mine === sent) live.innerHTML = html;
      }).catch(function () {});
    }
    function soon() {  // many events in a burst: one reload
      if (timer) return;
      timer = setTimeout(function () { timer = null; reload(); }, 300);
    }
    function onJob(job) {
      var row = live.querySelector('tr[data-job="' + job.id + '"]');
      if (row && row.dataset.status === job.status) paint(row, job);
      else if (row || firstPage) soon();
    }
    // the list stream tells of changes after it connects: what changed between the page's
    // rendering and the connection is fetched once when it opens
    stream(document.body.dataset.events, onJob, null, function () {
      liveState("polling every " + POLL_MS / 1000 + " s", "polling");
      every(POLL_MS, reload);
    }, reload);
  }

  document.addEventListener("DOMContentLoaded", function () {
    var page = document.body.dataset.page;
    if (page === "job") followJob(document.body.dataset.job);
    else if (page === "list") followList();
  });
})();
