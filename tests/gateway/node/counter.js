// A lean Foxglove WebSocket client for benchmarks/gateway.py: it counts message frames and
// parses nothing else of them, so that a turn measures the server more than the client.
//
// The same JSON lines as client.js, for the commands a benchmark turn uses (subscribe
// {channelId, quiet}, quiet {subscriptionId}, stats, close) and the events they wait on (open,
// advertise, unadvertise, status, subscribed, stats, done). It uses `ws` with Node's own
// Buffers (no ArrayBuffer copy).
//
//   node counter.js URL
'use strict';

const WebSocket = require('ws');
const { emit, serve, stats, tally } = require('./lines');

const [url] = process.argv.slice(2);
const ws = new WebSocket(url, ['foxglove.sdk.v1']);
const counted = new Map(); // subscription id -> {count, bytes, first, last}
let nextSubscription = 1;

ws.on('open', () => emit({ ev: 'open' }));
ws.on('error', (error) => emit({ ev: 'error', message: String(error && error.message) }));
ws.on('close', (code) => emit({ ev: 'close', code }));
ws.on('message', (data, isBinary) => {
  if (isBinary) {
    // message data: opcode 1, subscription id (u32), log time (u64), the message's bytes
    if (data[0] !== 1) {
      return;
    }
    const found = counted.get(data.readUInt32LE(1));
    if (found !== undefined) {
      tally(found, data.length - 13);
    }
    return;
  }
  const message = JSON.parse(data.toString('utf8'));
  if (message.op === 'advertise') {
    emit({ ev: 'advertise', channels: message.channels });
  } else if (message.op === 'unadvertise') {
    emit({ ev: 'unadvertise', channelIds: message.channelIds });
  } else if (message.op === 'status') {
    emit({ ev: 'status', status: message });
  }
});

const commands = {
  subscribe: (c) => {
    const subscriptionId = nextSubscription++;
    ws.send(JSON.stringify({ op: 'subscribe', subscriptions: [{ id: subscriptionId, channelId: c.channelId }] }));
    if (c.quiet) {
      commands.quiet({ subscriptionId });
    }
    emit({ ev: 'subscribed', channelId: c.channelId, subscriptionId });
  },
  quiet: (c) => counted.set(c.subscriptionId, { count: 0, bytes: 0, first: 0, last: 0 }),
  stats: () => emit(stats(counted)),
  close: () => ws.close(),
};

serve(commands, ws, () => ws.close());
