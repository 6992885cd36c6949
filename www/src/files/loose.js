// The question for loose files without a sensor in their names: they were loaded as the
// frames of one sensor (files.js groupNameless); the box says so and offers the other reading,
// one sensor per file.

// `group`: {sensor, scans} from groupNameless; `onSplit()`: the user says each file is a sensor.
export function renderLooseQuestion(container, group, onSplit) {
  if (!group) {
    container.replaceChildren();
    return;
  }
  const names = group.scans.map((s) => s.path);
  const box = document.createElement('div');
  box.className = 'loose';
  box.setAttribute('data-testid', 'loose-question');
  const text = document.createElement('p');
  text.textContent = `${names.length} files carry no sensor in their names (${names.slice(0, 4).join(', ')}${names.length > 4 ? ', …' : ''}). ` +
    `Taken as one sensor, ${group.sensor}, with ${names.length} frames. Is each file a sensor of its own instead?`;
  const keep = Object.assign(document.createElement('button'), { type: 'button', textContent: `Keep: one sensor, ${names.length} frames` });
  keep.addEventListener('click', () => container.replaceChildren());
  const split = Object.assign(document.createElement('button'), { type: 'button', textContent: 'Each file is a sensor' });
  split.addEventListener('click', () => {
    container.replaceChildren();
    onSplit();
  });
  const hint = document.createElement('p');
  hint.className = 'hint';
  hint.textContent = 'Name files <sensor>_<frame>.pcd (left_003.pcd) or put each sensor in a folder, and nothing needs asking. The table below reassigns any file by hand.';
  const buttons = document.createElement('div');
  buttons.className = 'buttons';
  buttons.append(keep, split);
  box.append(text, buttons, hint);
  container.replaceChildren(box);
}
