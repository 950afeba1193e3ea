/* roadsurvey survey report: "repair first", the damages an intervention rule flags, most severe
 * first; selecting one shows it on the map and in the table.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});
  const { isNum, el, clear, byId, fixed, M2, measure, mm } = R;

  const RANK = { high: 3, medium: 2, low: 1, none: 0 };

  // Severity first, then the deepest, then the largest; ties in the order a crew drives (chainage).
  function priorityOrder(a, b) {
    const pa = R.props(a), pb = R.props(b);
    const by = (x, y) => (isNum(y) ? y : -Infinity) - (isNum(x) ? x : -Infinity);
    return (RANK[R.severityOf(b)] - RANK[R.severityOf(a)]) || by(pa.max_depth_m, pb.max_depth_m) ||
      by(pa.area_m2, pb.area_m2) || -by(pa.chainage_m, pb.chainage_m) || a.id - b.id;
  }

  function whatAndWhere(d) {
    const p = R.props(d);
    const parts = [];
    if (isNum(p.max_depth_m)) parts.push(`${mm(p.max_depth_m)} mm deep`);
    if (isNum(p.area_m2)) parts.push(`${measure(p.area_m2, null, M2)} m²`);
    if (isNum(p.length_m)) parts.push(`${fixed(p.length_m, 2)} m long`);
    if (isNum(p.chainage_m)) parts.push(`at ${fixed(p.chainage_m, 1)} m`);
    return parts.join(' · ');
  }

  function renderPriorities(damages) {
    const box = clear(byId('priorities'));
    box.appendChild(el('h3', { text: 'Repair first' }));
    const flagged = damages.filter((d) => R.props(d).intervention === true).sort(priorityOrder);
    if (!flagged.length) {
      const none = damages.length ? 'No damage meets an intervention rule.' : 'No damage was found.';
      box.appendChild(el('p', { class: 'note', text: none }));
      return;
    }
    box.appendChild(el('p', { class: 'note', text: `${flagged.length} of ${damages.length} damages meet an ` +
      'intervention rule (hover for the rule); most severe, then deepest, first.' }));
    const list = el('ol', { class: 'priority-list' }, flagged.map((d) => {
      const button = el('button', { type: 'button', class: 'link-button', 'data-id': d.id,
        title: R.props(d).intervention_rule || null, text: `#${d.id} ${d.type}` });
      button.addEventListener('click', () => R.selectDamage(d.id, { zoom: true, scroll: true }));
      return el('li', {}, [button, ' ', R.severityBadge(d), ' ', el('span', { text: whatAndWhere(d) })]);
    }));
    box.appendChild(list);
  }

  Object.assign(R, { renderPriorities });
})();
