// Runs in the page before Studio (puppeteer's evaluateOnNewDocument): counts what reaches the
// page from the live view and when. Studio's WebSocket lives in a worker that posts every frame
// to the page; a wrapped Worker sees each frame as Studio's player gets it, and what the page
// sends (subscribe, advertise, setParameters, published messages). window.__abbProbe holds:
// counts by topic, the lag of each message (the page's clock minus the server's stamp, ms),
// the stamps themselves (ms), the page's animation frames, and what the page sent.
(() => {
  const probe = { frames: 0, channels: {}, subscriptions: {}, counts: {}, lags: {}, arrivals: {},
    stamps: {}, sent: [], published: 0, serverInfo: null, start: Date.now() };
  window.__abbProbe = probe;
  const KEEP = 20000;
  const tick = () => { probe.frames += 1; requestAnimationFrame(tick); };
  requestAnimationFrame(tick);
  const fromServer = (data) => {
    if (typeof data === "string") {
      const message = JSON.parse(data);
      if (message.op === "serverInfo") probe.serverInfo = message;
      if (message.op === "advertise") {
        for (const channel of message.channels) probe.channels[channel.id] = channel.topic;
      }
      return;
    }
    const view = new DataView(data);
    if (view.getUint8(0) !== 1) return;   // message data: op, subscription id, log time, CDR
    const topic = probe.subscriptions[view.getUint32(1, true)] || "?";
    const now = Date.now();
    probe.counts[topic] = (probe.counts[topic] || 0) + 1;
    const lags = (probe.lags[topic] = probe.lags[topic] || []);
    const arrivals = (probe.arrivals[topic] = probe.arrivals[topic] || []);
    const stamps = (probe.stamps[topic] = probe.stamps[topic] || []);
    if (lags.length < KEEP) {
      const stamp = Number(view.getBigUint64(5, true)) / 1e6;
      lags.push(now - stamp);
      arrivals.push(now - probe.start);
      stamps.push(stamp);
    }
  };
  const fromPage = (data) => {
    if (typeof data !== "string") { probe.published += 1; return; }
    const message = JSON.parse(data);
    probe.sent.push(message);
    if (message.op === "subscribe") {
      for (const s of message.subscriptions) probe.subscriptions[s.id] = probe.channels[s.channelId];
    }
  };
  const NativeWorker = window.Worker;
  window.Worker = class extends NativeWorker {
    constructor(...args) {
      super(...args);
      this.addEventListener("message", (event) => {
        if (event.data && event.data.type === "message") fromServer(event.data.data);
      });
    }

    postMessage(message, ...rest) {
      if (message && message.type === "data") fromPage(message.data);
      return super.postMessage(message, ...rest);
    }
  };
})();
