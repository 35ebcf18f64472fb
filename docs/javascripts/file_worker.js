/*
 * Search from disk. A browser will not start a web worker from a file://
 * page, and the theme searches in one. Opened from disk, this runs the
 * worker's script in a hidden frame of the page instead and passes the
 * messages both ways; served over HTTP it does nothing. tools/mkdocs_hooks.py
 * puts it where the theme's offline plugin would load a shim from the web.
 */
(function () {
  "use strict";
  if (location.protocol !== "file:") {
    return;
  }

  function FileWorker(url) {
    var worker = this;
    var listeners = {message: [], error: []};
    var waiting = [];
    var loaded = false;
    var frame = document.createElement("iframe");
    frame.style.display = "none";
    frame.setAttribute("aria-hidden", "true");
    (document.body || document.documentElement).appendChild(frame);
    var scope = frame.contentWindow;

    function emit(type, event) {
      var handler = worker["on" + type];
      if (typeof handler === "function") {
        handler.call(worker, event);
      }
      listeners[type].slice().forEach(function (listener) {
        listener.call(worker, event);
      });
    }

    function deliver(data) {
      scope.dispatchEvent(new scope.MessageEvent("message", {data: data}));
    }

    // the worker's side: what it posts reaches the page's listeners
    scope.postMessage = function (data) {
      setTimeout(function () {
        emit("message", new MessageEvent("message", {data: data}));
      }, 0);
    };
    scope.importScripts = function () {
      throw new Error("importScripts is not available to a worker run from disk");
    };
    scope.addEventListener("error", function (event) {
      emit("error", event);
    });

    var script = scope.document.createElement("script");
    script.src = new URL(url, location.href).href;
    script.onload = function () {
      loaded = true;
      waiting.splice(0).forEach(deliver);
    };
    script.onerror = function (event) {
      emit("error", event);
    };
    scope.document.head.appendChild(script);

    this.onmessage = null;
    this.onerror = null;
    this.postMessage = function (data) {
      if (loaded) {
        setTimeout(function () { deliver(data); }, 0);
      } else {
        waiting.push(data);
      }
    };
    this.addEventListener = function (type, listener) {
      (listeners[type] = listeners[type] || []).push(listener);
    };
    this.removeEventListener = function (type, listener) {
      listeners[type] = (listeners[type] || []).filter(function (l) { return l !== listener; });
    };
    this.terminate = function () {
      frame.remove();
    };
  }

  window.Worker = FileWorker;
})();
