/* roadsurvey survey report: a damage's fields, its governing grade and severity, and the text
 * a search matches.
 */
(function () {
  'use strict';

  const R = (window.RoadsurveyReport = window.RoadsurveyReport || {});
  const { SEVERITY_COLOURS, isText, el } = R;

  // ---------------------------------------------------------------------------------------------
  // Damage fields

  function props(d) {
    return d.properties || {};
  }

  /** The grade that sets the severity: FHWA LTPP for cracks, ASTM D6433 for depressions. */
  function governingRule(d) {
    const p = props(d);
    const astm = { standard: 'ASTM D6433', rule: p.astm_d6433_rule };
    const fhwa = { standard: 'FHWA LTPP', rule: p.fhwa_ltpp_rule };
    const [first, second] = d.type === 'crack' ? [fhwa, astm] : [astm, fhwa];
    if (isText(first.rule)) return first;
    if (isText(second.rule)) return second;
    return { standard: null, rule: null };
  }

  function severityOf(d) {
    return SEVERITY_COLOURS[d.severity] ? d.severity : 'none';
  }

  function severityBadge(d) {
    const sev = severityOf(d);
    const g = governingRule(d);
    return el('span', { class: `sev sev-${sev}`, text: sev, title: g.rule || 'no grading rule recorded' });
  }

  /** Text a search can match: what a reader may remember about a damage. */
  function searchText(d) {
    const p = props(d);
    return [d.id, d.type, d.severity, p.astm_d6433_rule, p.fhwa_ltpp_rule, p.intervention_rule, p.basis,
      p.observation_frames, p.best_frame].filter((v) => v !== null && v !== undefined).join(' ').toLowerCase();
  }

  Object.assign(R, { props, governingRule, severityOf, severityBadge, searchText });
})();
