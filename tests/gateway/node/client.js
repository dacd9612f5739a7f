// A Foxglove WebSocket client for the zros gateway tests, driven over stdin/stdout.
//
// It is the @foxglove/ws-protocol client from npm (the library Foxglove publishes for its
// protocol) with a thin command layer: one JSON command per stdin line, one JSON event per
// stdout line. Binary data travels as base64; 64-bit times as decimal strings.
//
//   node client.js URL [--ca FILE] [--protocol NAME] [--origin ORIGIN]
//
// The socket offers the library's own subprotocol (FoxgloveClient.SUPPORTED_SUBPROTOCOL,
// foxglove.websocket.v1), as its README opens one, unless --protocol names another (the
// Foxglove SDK's foxglove.sdk.v1); --origin sends an Origin header, as a browser's page would.
//
// Commands: subscribe {channelId, quiet?, latency?}, unsubscribe {subscriptionId}, quiet
// {subscriptionId, latency} (count its messages, the seconds from the first to the last and,
// with latency, how long after the stamp at bytes 4-12 each arrived, instead of reporting
// each; subscribe's quiet does so from the subscription's first message), stats, advertise
// {topic, encoding, schemaName, schema?, schemaEncoding?}, publish {channelId, data},
// callService {serviceId, callId, encoding, data}, getParameters {names, id},
// setParameters {parameters, id}, subscribeParameterUpdates {names},
// unsubscribeParameterUpdates {names}, subscribeConnectionGraph, fetchAsset {uri, requestId},
// playback {command, speed, seek, requestId}, pauseReading, resumeReading, close.
'use strict';

const fs = require('fs');
const { FoxgloveClient } = require('@foxglove/ws-protocol');
const WebSocket = require('ws');
const { emit, serve, stats, tally } = require('./lines');

const [url, ...rest] = process.argv.slice(2);
const flags = {};
for (let i = 0; i + 1 < rest.length; i += 2) {
  flags[rest[i].replace(/^--/, '')] = rest[i + 1];
}
const options = {};
if (flags.ca) {
  options.ca = fs.readFileSync(flags.ca);
}
if (flags.origin) {
  options.origin = flags.origin;
}
const ws = new WebSocket(url, [flags.protocol || FoxgloveClient.SUPPORTED_SUBPROTOCOL], options);
const client = new FoxgloveClient({ ws });

function b64(view) {
  return Buffer.from(view.buffer, view.byteOffset, view.byteLength).toString('base64');
}

function bytes(text) {
  return new Uint8Array(Buffer.from(text, 'base64'));
}

function nowNs() {
  return (performance.timeOrigin + performance.now()) * 1e6;
}

const quiet = new Map(); // subscription id -> {count, bytes, latencies}

client.on('open', () => emit({ ev: 'open' }));
client.on('error', (error) => {
  const message = String(error && error.message);
  if (!message.includes('opcode in binary message: 5')) { // the playback state, read below
    emit({ ev: 'error', message });
  }
});
client.on('close', (event) => emit({ ev: 'close', code: event && event.code }));
// the HTTP answer to a refused upgrade (the library reports only that the socket failed)
ws.on('unexpected-response', (request, response) => {
  emit({ ev: 'refused', status: response.statusCode });
  ws.terminate();
});
client.on('serverInfo', (info) => emit({ ev: 'serverInfo', info }));
client.on('status', (status) => emit({ ev: 'status', status }));
client.on('removeStatus', (message) => emit({ ev: 'removeStatus', statusIds: message.statusIds }));
client.on('advertise', (channels) => emit({ ev: 'advertise', channels }));
client.on('unadvertise', (channelIds) => emit({ ev: 'unadvertise', channelIds }));
client.on('advertiseServices', (services) => emit({ ev: 'advertiseServices', services }));
client.on('unadvertiseServices', (serviceIds) => emit({ ev: 'unadvertiseServices', serviceIds }));
client.on('parameterValues', (message) => emit({ ev: 'parameterValues', ...message }));
client.on('connectionGraphUpdate', (message) => emit({ ev: 'connectionGraphUpdate', ...message }));
client.on('time', (message) => emit({ ev: 'time', timestamp: message.timestamp.toString() }));
client.on('serviceCallFailure', (message) => emit({ ev: 'serviceCallFailure', ...message }));
client.on('serviceCallResponse', (message) => {
  emit({
    ev: 'serviceCallResponse',
    serviceId: message.serviceId,
    callId: message.callId,
    encoding: message.encoding,
    data: b64(message.data),
  });
});
client.on('fetchAssetResponse', (message) => {
  const event = { ev: 'fetchAssetResponse', requestId: message.requestId, status: message.status };
  if (message.data !== undefined) {
    event.data = b64(message.data);
  } else {
    event.error = message.error;
  }
  emit(event);
});
client.on('message', (message) => {
  const counted = quiet.get(message.subscriptionId);
  if (counted !== undefined) {
    tally(counted, message.data.byteLength);
    if (counted.latency && message.data.byteLength >= 12) {
      const sec = message.data.getInt32(4, true);
      const nanosec = message.data.getUint32(8, true);
      counted.latencies.push(nowNs() - (sec * 1e9 + nanosec));
    }
    return;
  }
  emit({
    ev: 'message',
    subscriptionId: message.subscriptionId,
    timestamp: message.timestamp.toString(),
    data: b64(message.data),
  });
});

// The playback state (binary opcode 5) is newer than this version of the library.
ws.on('message', (raw, isBinary) => {
  const data = Buffer.from(raw); // an ArrayBuffer: the library set binaryType
  if (!isBinary || data.length < 19 || data[0] !== 5) {
    return;
  }
  // op, status, current time (u64), speed (f32), did seek (u8), request id (u32 length + text)
  const idLength = data.readUInt32LE(15);
  emit({
    ev: 'playbackState',
    status: data[1],
    currentTime: data.readBigUInt64LE(2).toString(),
    speed: data.readFloatLE(10),
    didSeek: data[14] !== 0,
    requestId: data.subarray(19, 19 + idLength).toString('utf8'),
  });
});

function playback(command) {
  const id = Buffer.from(command.requestId, 'utf8');
  const payload = Buffer.alloc(1 + 1 + 4 + 1 + 8 + 4 + id.length);
  let offset = payload.writeUInt8(3, 0); // the client's playback control opcode
  offset = payload.writeUInt8(command.command, offset);
  offset = payload.writeFloatLE(command.speed, offset);
  offset = payload.writeUInt8(command.seek === null ? 0 : 1, offset);
  offset = payload.writeBigUInt64LE(BigInt(command.seek === null ? 0 : command.seek), offset);
  offset = payload.writeUInt32LE(id.length, offset);
  id.copy(payload, offset);
  ws.send(payload);
}

const commands = {
  subscribe: (c) => {
    const subscriptionId = client.subscribe(c.channelId);
    if (c.quiet) { // counted from its first message on
      commands.quiet({ subscriptionId, latency: c.latency });
    }
    emit({ ev: 'subscribed', channelId: c.channelId, subscriptionId });
  },
  unsubscribe: (c) => client.unsubscribe(c.subscriptionId),
  quiet: (c) => quiet.set(c.subscriptionId, { count: 0, bytes: 0, first: 0, last: 0, latency: !!c.latency, latencies: [] }),
  stats: () => emit(stats(quiet)),
  advertise: (c) => {
    const channel = { topic: c.topic, encoding: c.encoding, schemaName: c.schemaName };
    if (c.schema !== undefined) {
      channel.schema = c.schema;
      channel.schemaEncoding = c.schemaEncoding;
    }
    emit({ ev: 'advertised', topic: c.topic, channelId: client.advertise(channel) });
  },
  unadvertise: (c) => client.unadvertise(c.channelId),
  publish: (c) => client.sendMessage(c.channelId, bytes(c.data)),
  callService: (c) => client.sendServiceCallRequest({ serviceId: c.serviceId, callId: c.callId, encoding: c.encoding, data: new DataView(bytes(c.data).buffer) }),
  getParameters: (c) => client.getParameters(c.names, c.id),
  setParameters: (c) => client.setParameters(c.parameters, c.id),
  subscribeParameterUpdates: (c) => client.subscribeParameterUpdates(c.names),
  unsubscribeParameterUpdates: (c) => client.unsubscribeParameterUpdates(c.names),
  subscribeConnectionGraph: () => client.subscribeConnectionGraph(),
  fetchAsset: (c) => client.fetchAsset(c.uri, c.requestId),
  playback,
  // stop reading the socket: the server's outbox for this client fills up
  pauseReading: () => ws._socket.pause(),
  resumeReading: () => ws._socket.resume(),
  close: () => client.close(),
};

serve(commands, ws, () => client.close());
