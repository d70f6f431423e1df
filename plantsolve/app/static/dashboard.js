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

// The upload form's options, generated from the kind's options JSON schema (embedded in the page as
// #options-schema): a number, check box, choice or text field per option (a multi-line field with a file
// picker for an option that holds a file's text), each starting at the value the JSON text shows (the
// defaults); nested objects and lists stay JSON. Every change writes the JSON text,
// which is what the form posts; without this script the JSON text alone is the form.
(function () {
  "use strict";
  // a string option longer than this is the text of a file: a multi-line field with a file picker
  var LONG_TEXT = 1000;

  function resolve(schema, root) {
    while (schema && schema.$ref) schema = root.$defs[schema.$ref.split("/").pop()];
    return schema || {};
  }

  // the option's own schema: a nullable one (anyOf [X, null]) is X, allowed to be empty
  function shape(schema, root) {
    schema = resolve(schema, root);
    var choices = schema.anyOf || schema.oneOf;
    if (choices) {
      var real = choices.map(function (c) { return resolve(c, root); }).filter(function (c) { return c.type !== "null"; });
      if (real.length === 1 && real[0].type === "boolean") {
        // null is a third answer ("the kind decides"): a choice of (not set), true, false, not a check box
        return { enum: [true, false], nullable: true, description: schema.description || real[0].description };
      }
      if (real.length === 1) return Object.assign({}, real[0], { nullable: true, description: schema.description || real[0].description });
      if (real.every(function (c) { return c.const !== undefined || c.enum; })) {
        var values = [];
        real.forEach(function (c) { values = values.concat(c.enum || [c.const]); });
        return { enum: values, nullable: real.length < choices.length, description: schema.description };
      }
      return { description: schema.description };  // a union of shapes: JSON
    }
    if (schema.const !== undefined) return Object.assign({}, schema, { enum: [schema.const] });
    return schema;
  }

  function field(name, schema, value) {
    var wrap = document.createElement("label");
    wrap.className = "option";
    wrap.title = schema.description || "";
    var caption = document.createElement("span");
    caption.textContent = name;
    var input, picker;
    if (schema.enum) {
      input = document.createElement("select");
      var list = schema.nullable ? [null].concat(schema.enum) : schema.enum;
      list.forEach(function (v) {
        var option = document.createElement("option");
        option.value = JSON.stringify(v);
        option.textContent = v === null ? "(not set)" : String(v);
        if (JSON.stringify(v) === JSON.stringify(value === undefined ? null : value)) option.selected = true;
        input.appendChild(option);
      });
      input.read = function () { return JSON.parse(input.value); };
    } else if (schema.type === "boolean") {
      input = document.createElement("input");
      input.type = "checkbox";
      input.checked = value === true;
      input.read = function () { return input.checked; };
    } else if (schema.type === "number" || schema.type === "integer") {
      input = document.createElement("input");
      input.type = "number";
      input.step = schema.type === "integer" ? "1" : "any";
      if (schema.minimum !== undefined) input.min = schema.minimum;
      if (schema.maximum !== undefined) input.max = schema.maximum;
      input.value = value === undefined || value === null ? "" : String(value);
      input.read = function () { return input.value === "" ? undefined : Number(input.value); };
    } else if (schema.type === "string" && schema.maxLength > LONG_TEXT) {
      // the text of a file (a tube's nominal CSV): lines kept, typed or pasted here or read from a chosen file
      input = document.createElement("textarea");
      input.rows = 6;
      input.spellcheck = false;
      input.wrap = "off";
      input.value = value === undefined || value === null ? "" : value;
      input.read = function () { return input.value === "" ? undefined : input.value; };
      var picker = document.createElement("input");
      picker.type = "file";
      picker.name = "";  // not posted: its text goes into the field
      picker.dataset.fileFor = name;
      picker.addEventListener("change", function () {
        var file = picker.files && picker.files[0];
        if (!file) return;
        file.text().then(function (text) {
          input.value = text;
          input.dispatchEvent(new Event("change"));
        });
      });
    } else if (schema.type === "string") {
      input = document.createElement("input");
      input.type = "text";
      input.value = value === undefined || value === null ? "" : value;
      input.read = function () { return input.value === "" ? undefined : input.value; };
    } else {  // objects, lists, unions: JSON, the default prefilled
      input = document.createElement("textarea");
      input.rows = 2;
      input.spellcheck = false;
      input.value = value === undefined ? "" : JSON.stringify(value);
      input.read = function () {
        if (input.value.trim() === "") return undefined;
        try { input.setCustomValidity(""); return JSON.parse(input.value); }
        catch (e) { input.setCustomValidity("not JSON: " + e.message); return input.value; }
      };
    }
    input.name = "";  // not posted itself: the JSON text is
    input.dataset.option = name;
    wrap.appendChild(caption);
    wrap.appendChild(input);
    if (picker) {
      wrap.classList.add("option-text");
      var from = document.createElement("span");
      from.className = "file-source";
      from.textContent = "or read it from a file: ";
      from.appendChild(picker);
      wrap.appendChild(from);
    }
    if (schema.description) {
      var help = document.createElement("small");
      help.textContent = schema.description;
      wrap.appendChild(help);
    }
    return { element: wrap, input: input };
  }

  function build() {
    var holder = document.getElementById("option-fields");
    var schemaEl = document.getElementById("options-schema");
    var text = document.getElementById("options-json");
    if (!holder || !schemaEl || !text) return;
    var root = JSON.parse(schemaEl.textContent);
    var shown;
    try { shown = JSON.parse(text.value || "{}"); } catch (e) { return; }  // a text with an error: leave it
    var inputs = [];
    Object.keys(root.properties || {}).forEach(function (name) {
      var made = field(name, shape(root.properties[name], root), shown[name]);
      inputs.push(made.input);
      holder.appendChild(made.element);
    });
    function write() {
      var current;
      try { current = JSON.parse(text.value || "{}"); } catch (e) { current = {}; }
      inputs.forEach(function (input) {
        var v = input.read();
        if (v === undefined || v === null) delete current[input.dataset.option];
        else current[input.dataset.option] = v;
      });
      text.value = JSON.stringify(current, null, 2);
    }
    inputs.forEach(function (input) {
      input.addEventListener("change", write);
      input.addEventListener("input", write);
    });
    holder.hidden = false;
    text.closest("details").open = false;  // the fields are the form now; the JSON stays one click away
  }

  document.addEventListener("DOMContentLoaded", build);
})();

// Plots open full size: a click on a plot shows it at its own resolution in a viewer over the page (scrolled
// when larger than the window; a click on the image toggles fitting it to the window); Escape or the close
// button ends it. Delegated from the document: the job's detail is swapped in anew on status changes.
(function () {
  "use strict";

  function viewer() {
    var dialog = document.getElementById("plot-viewer");
    if (dialog) return dialog;
    dialog = document.createElement("dialog");
    dialog.id = "plot-viewer";
    dialog.className = "plot-viewer";
    var bar = document.createElement("div");
    bar.className = "viewer-bar";
    var title = document.createElement("span");
    title.className = "viewer-title";
    var download = document.createElement("a");
    download.className = "viewer-download";
    download.textContent = "download";
    download.setAttribute("download", "");
    var close = document.createElement("button");
    close.type = "button";
    close.className = "viewer-close";
    close.textContent = "Close";
    close.addEventListener("click", function () { dialog.close(); });
    bar.appendChild(title);
    bar.appendChild(download);
    bar.appendChild(close);
    var frame = document.createElement("div");
    frame.className = "viewer-frame";
    var img = document.createElement("img");
    img.addEventListener("click", function () { dialog.classList.toggle("fit"); });
    frame.appendChild(img);
    dialog.appendChild(bar);
    dialog.appendChild(frame);
    dialog.addEventListener("click", function (event) { if (event.target === dialog) dialog.close(); });
    document.body.appendChild(dialog);
    return dialog;
  }

  document.addEventListener("click", function (event) {
    var link = event.target.closest && event.target.closest("a.plot-open");
    if (!link || event.ctrlKey || event.metaKey || event.shiftKey) return;
    event.preventDefault();
    var dialog = viewer();
    dialog.classList.remove("fit");
    dialog.querySelector("img").src = link.href;
    dialog.querySelector("img").alt = link.dataset.name || "";
    dialog.querySelector(".viewer-title").textContent = link.dataset.name || "";
    dialog.querySelector(".viewer-download").href = link.href;
    dialog.showModal();
  });
})();
