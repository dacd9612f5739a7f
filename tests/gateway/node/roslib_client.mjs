// A rosbridge client for the zros gateway tests, driven over stdin/stdout: roslib (roslibjs,
// the library web apps use) from npm, run by node, with a thin command layer. One JSON command
// per stdin line, one JSON event per stdout line.
//
//   node roslib_client.mjs URL
//
// Commands (each may carry a "tag" echoed in its events):
//   subscribe {topic, type, compression?, throttle_rate?, queue_length?, summary?}
//     -> message {topic, msg} per message; with summary, msg is replaced by {width, height,
//        size, first} (an image's shape, the byte length of its data, its first byte)
//   unsubscribe {topic}, publish {topic, type, msg}
//   call {service, type, args} -> response {values} or failure {error}
//   serve {service, type} -> each request answered with {sum: a + b} (AddTwoInts), request
//        events {args}; a negative a fails the call
//   goal {action, type, goal, cancel_after?} -> feedback {values}, result {values} or
//        failure {error}; with cancel_after, canceled after that many feedback messages
//   serve_action {action, type} -> serves Fibonacci goals: goal {id, goal} events, feedback
//        at each step, then succeeded; order < 0 fails (setFailed); order 0 waits for a
//        cancel (cancel {id} event, then setCanceled)
//   unserve_action {action}
//   rosapi {what, args} -> rosapi {what, value} (getTopics, getNodes, getParams, ...)
//   param_get {name} / param_set {name, value} -> param {value} / param_set_done
//   close
'use strict';

import readline from 'node:readline';
import * as ROSLIB from 'roslib';

const [url] = process.argv.slice(2);
const ros = new ROSLIB.Ros({ url });
const topics = new Map();
const actions = new Map();

function emit(event) {
  process.stdout.write(JSON.stringify(event) + '\n');
}

function summary(msg) {
  const data = msg.data;
  let size = 0;
  let first = null;
  if (typeof data === 'string') { // base64 in JSON
    const bytes = Buffer.from(data, 'base64');
    size = bytes.length;
    first = bytes.length ? bytes[0] : null;
  } else if (data && data.length !== undefined) { // a Uint8Array from CBOR
    size = data.length;
    first = data.length ? data[0] : null;
  }
  return { width: msg.width, height: msg.height, size, first, stamp: msg.header && msg.header.stamp };
}

ros.on('connection', () => emit({ ev: 'open' }));
ros.on('error', (error) => emit({ ev: 'error', message: String(error && error.message) }));
ros.on('close', () => emit({ ev: 'close' }));
ros.on('status', (status) => emit({ ev: 'status', status }));

const commands = {
  subscribe(c) {
    const topic = new ROSLIB.Topic({
      ros,
      name: c.topic,
      messageType: c.type,
      compression: c.compression || 'none',
      throttle_rate: c.throttle_rate || 0,
      queue_length: c.queue_length || 0,
    });
    topic.subscribe((msg) => {
      const received = performance.timeOrigin + performance.now();
      emit({ ev: 'message', tag: c.tag, topic: c.topic, received, msg: c.summary ? summary(msg) : msg });
    });
    topics.set(c.topic, topic);
  },
  unsubscribe(c) {
    topics.get(c.topic).unsubscribe();
  },
  publish(c) {
    let topic = topics.get('pub:' + c.topic);
    if (!topic) {
      topic = new ROSLIB.Topic({ ros, name: c.topic, messageType: c.type });
      topics.set('pub:' + c.topic, topic);
    }
    topic.publish(c.msg);
  },
  call(c) {
    const service = new ROSLIB.Service({ ros, name: c.service, serviceType: c.type });
    service.callService(
      c.args,
      (values) => emit({ ev: 'response', tag: c.tag, values }),
      (error) => emit({ ev: 'failure', tag: c.tag, error: String(error) }),
    );
  },
  serve(c) {
    const service = new ROSLIB.Service({ ros, name: c.service, serviceType: c.type });
    service.advertise((request, response) => {
      emit({ ev: 'request', tag: c.tag, args: request });
      if (request.a < 0) {
        return false;
      }
      response.sum = request.a + request.b;
      return true;
    });
  },
  goal(c) {
    const action = new ROSLIB.Action({ ros, name: c.action, actionType: c.type });
    let feedbacks = 0;
    let id = null;
    id = action.sendGoal(
      c.goal,
      (values) => emit({ ev: 'result', tag: c.tag, values }),
      (values) => {
        emit({ ev: 'feedback', tag: c.tag, values });
        feedbacks += 1;
        if (c.cancel_after && feedbacks === c.cancel_after) {
          action.cancelGoal(id);
        }
      },
      (error) => emit({ ev: 'failure', tag: c.tag, error: String(error) }),
    );
  },
  serve_action(c) {
    const action = new ROSLIB.Action({ ros, name: c.action, actionType: c.type });
    action.advertise(
      (goal, id) => {
        emit({ ev: 'goal', tag: c.tag, id, goal });
        if (goal.order < 0) {
          action.setFailed(id);
        } else if (goal.order > 0) {
          const sequence = [0, 1];
          for (let i = 1; i < goal.order; i += 1) {
            sequence.push(sequence[i] + sequence[i - 1]);
            action.sendFeedback(id, { sequence: [...sequence] });
          }
          action.setSucceeded(id, { sequence });
        }
      },
      (id) => {
        emit({ ev: 'cancel', tag: c.tag, id });
        action.setCanceled(id, { sequence: [0] });
      },
    );
    actions.set(c.action, action);
  },
  unserve_action(c) {
    actions.get(c.action).unadvertise();
  },
  rosapi(c) {
    const args = [...(c.args || []), (value) => emit({ ev: 'rosapi', tag: c.tag, what: c.what, value }),
      (error) => emit({ ev: 'failure', tag: c.tag, error: String(error) })];
    ros[c.what](...args);
  },
  param_get(c) {
    new ROSLIB.Param({ ros, name: c.name }).get(
      (value) => emit({ ev: 'param', tag: c.tag, value }),
      (error) => emit({ ev: 'failure', tag: c.tag, error: String(error) }),
    );
  },
  param_set(c) {
    new ROSLIB.Param({ ros, name: c.name }).set(
      c.value,
      () => emit({ ev: 'param_set_done', tag: c.tag }),
      (error) => emit({ ev: 'failure', tag: c.tag, error: String(error) }),
    );
  },
  close() {
    ros.close();
    process.exit(0);
  },
};

const lines = readline.createInterface({ input: process.stdin });
lines.on('close', () => commands.close()); // stdin closed: the test is done with this client
lines.on('line', (line) => {
  const command = JSON.parse(line);
  try {
    commands[command.cmd](command);
  } catch (error) {
    emit({ ev: 'error', tag: command.tag, message: String(error && error.stack) });
  }
});
