// Yielding to the event loop between steps of a long job, so the page (or a worker's other
// messages) get a turn. Not setTimeout(0): once timers nest five deep it waits at least 4 ms,
// which a loop yielding per item pays on every item (a 212-scan rig's input copy: 0.85 s). A
// message posted to ourselves is not clamped.
export const nextTask = () => new Promise((resolve) => {
  const channel = new MessageChannel();
  channel.port1.onmessage = () => {
    channel.port1.close(); // an open port would keep Node's event loop alive
    resolve();
  };
  channel.port2.postMessage(null);
});
