// Connect Foxglove's WebSocket protocol client (@foxglove/ws-protocol) to a live view and
// print, as one JSON object, what it saw: the server info, the channels and services
// advertised, the first messages of every channel (base64) and how many came, and the
// answers to what it sent.
//
// node client.mjs URL '{"messages": 3, "timeout_s": 20, "publish": [...], "calls": [...]}'
//   publish: [{"topic", "schemaName", "data" (base64 CDR)}]  (clientPublish)
//   calls:   [{"service", "data" (base64 CDR)}]              (services)
//   wait_for: the topics that must have "messages" messages (default every channel's)
//   get_parameters: [names], then set_parameters: [{"name", "value"}]  (parameters)
//   subprotocol: the one offered (default: the client's own, FoxgloveClient.SUPPORTED_SUBPROTOCOL,
//     "foxglove.websocket.v1"); origin: an Origin header to send, as a browser does
//   statuses: how many status messages to wait for (they are kept in "statuses")
// SIGUSR1 prints {"counts": ...} so far on a line of its own; SIGTERM ends it, printing all.
// A handshake the server refuses ends the client at once with "handshake": the HTTP status.
import protocol from "@foxglove/ws-protocol";
import WebSocket from "ws";
import { readFileSync } from "node:fs";

const { FoxgloveClient } = protocol;

const [url, optionsArg] = process.argv.slice(2);
const optionsText = optionsArg === "-" ? readFileSync(0, "utf8") : optionsArg;   // "-": from stdin
const options = { messages: 3, timeout_s: 20, publish: [], calls: [], get_parameters: null,
  set_parameters: null, subprotocol: FoxgloveClient.SUPPORTED_SUBPROTOCOL, origin: null, statuses: 0,
  ...JSON.parse(optionsText || "{}") };
const parameterRequests = (options.get_parameters ? 1 : 0) + (options.set_parameters ? 1 : 0);
const b64 = (view) => Buffer.from(view.buffer, view.byteOffset, view.byteLength).toString("base64");

const seen = { serverInfo: null, channels: [], services: [], messages: {}, counts: {}, time: [], responses: [], failures: [],
  parameters: {}, statuses: [], subprotocol: null };
const socket = new WebSocket(url, [options.subprotocol], options.origin ? { origin: options.origin } : {});
socket.on("open", () => { seen.subprotocol = socket.protocol; });
socket.on("unexpected-response", (request, response) => {
  seen.handshake = response.statusCode;
  finish(0);
});
const client = new FoxgloveClient({ ws: socket });
const bySubscription = new Map();
let finished = false;

function finish(code) {
  if (finished) return;
  finished = true;
  process.stdout.write(JSON.stringify(seen) + "\n");
  if (seen.handshake === undefined) client.close();
  process.exit(code);
}

function done() {
  const topics = options.wait_for || seen.channels.map((c) => c.topic);
  const enough = seen.channels.length > 0 && topics.every(
    (topic) => (seen.messages[topic] || []).length >= options.messages);
  return enough && seen.statuses.length >= options.statuses && seen.responses.length + seen.failures.length >= options.calls.length
    && Object.keys(seen.parameters).length >= parameterRequests;
}

setTimeout(() => finish(0), options.timeout_s * 1000);
process.on("SIGTERM", () => finish(0));   // ended from outside: print what was seen
// asked from outside how far it got: one line of the counts so far, and go on
process.on("SIGUSR1", () => process.stdout.write(JSON.stringify({ counts: seen.counts }) + "\n"));
client.on("error", (error) => { seen.error = String(error); finish(1); });
client.on("serverInfo", (info) => { seen.serverInfo = info; });
client.on("time", (event) => { if (seen.time.length < 10) seen.time.push(String(event.timestamp)); });
client.on("advertise", (channels) => {
  for (const channel of channels) {
    seen.channels.push(channel);
    bySubscription.set(client.subscribe(channel.id), channel);
  }
});
client.on("advertiseServices", (services) => {
  seen.services.push(...services);
  for (const call of options.calls) {
    const service = services.find((s) => s.name === call.service);
    if (service === undefined) continue;
    client.sendServiceCallRequest({ serviceId: service.id, callId: seen.services.length * 100 + options.calls.indexOf(call),
      encoding: "cdr", data: new DataView(Uint8Array.from(Buffer.from(call.data, "base64")).buffer) });
  }
});
client.on("serviceCallResponse", (event) => { seen.responses.push({ serviceId: event.serviceId, data: b64(event.data) }); });
client.on("status", (event) => { seen.statuses.push(event); if (done()) setTimeout(() => finish(0), 300); });
client.on("serviceCallFailure", (event) => { seen.failures.push(event); });
client.on("parameterValues", (event) => { seen.parameters[event.id] = event.parameters; });
client.on("message", (event) => {
  const channel = bySubscription.get(event.subscriptionId);
  seen.counts[channel.topic] = (seen.counts[channel.topic] || 0) + 1;
  const list = (seen.messages[channel.topic] ||= []);
  if (list.length < options.messages) list.push({ logTime: String(event.timestamp), data: b64(event.data) });
  if (done()) setTimeout(() => finish(0), 300);   // the server takes what was sent first
});
client.on("open", () => {
  if (options.get_parameters) client.getParameters(options.get_parameters, "get");
  if (options.set_parameters) client.setParameters(options.set_parameters, "set");
  for (const message of options.publish) {
    const id = client.advertise({ topic: message.topic, encoding: "cdr", schemaName: message.schemaName });
    client.sendMessage(id, Uint8Array.from(Buffer.from(message.data, "base64")));
  }
});
