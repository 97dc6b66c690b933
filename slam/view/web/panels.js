// The side panels of coloc view: counts, the live frame, a keyframe's image with its features,
// and the registration report.
const $ = (id) => document.getElementById(id);
const fmt = (v, d = 2) => (v === null || v === undefined || v < 0 ? '-' : Number(v).toFixed(d));

export function setCounts(c) {
  const set = (id, v) => { if (v !== undefined) $(id).textContent = v; };
  set('count-keyframes', c.keyframes); set('count-points', c.points);
  set('count-slam-markers', c.slamMarkers); set('count-scan-markers', c.scanMarkers);
  set('count-scan-points', c.scanPoints); set('count-loops', c.loops); set('frame', c.frame);
}

// Keypoints (flat x, y list; tracked: '0'/'1' per keypoint) and marker quads over an image of
// width x height pixels.
function drawFeatures(canvas, width, height, keypoints, tracked, markers) {
  canvas.width = width; canvas.height = height;
  canvas.style.height = (400 * height / width) + 'px';
  const g = canvas.getContext('2d');
  g.clearRect(0, 0, width, height);
  for (let i = 0; i < keypoints.length / 2; ++i) {
    const on = tracked[i] === '1';
    g.strokeStyle = on ? '#3f3' : '#f55';
    g.lineWidth = 1;
    g.strokeRect(keypoints[2 * i] - 2.5, keypoints[2 * i + 1] - 2.5, 5, 5);
  }
  g.lineWidth = 2.5; g.strokeStyle = '#ff9d2e'; g.fillStyle = '#ff9d2e'; g.font = 'bold 16px sans-serif';
  for (const m of markers || []) {
    const c = m.corners;
    g.beginPath(); g.moveTo(c[0], c[1]);
    for (let k = 1; k < 4; ++k) g.lineTo(c[2 * k], c[2 * k + 1]);
    g.closePath(); g.stroke();
    g.fillText(String(m.id), c[0] + 3, c[1] - 4);
  }
}

export function showLive(f) {
  const st = $('live-state');
  st.textContent = f.state; st.className = 'state ' + f.state;
  $('live-index').textContent = f.index;
  $('live-time').textContent = f.t.toFixed(3);
  $('live-inliers').textContent = f.inliers;
  $('live-ms').textContent = f.track_ms.toFixed(1);
  $('live-position').textContent = f.pose ? f.pose.slice(4).map((v) => v.toFixed(3)).join(', ') : 'lost';
  $('live-position').dataset.index = f.index;
  const img = $('live-image');
  img.onload = () => drawFeatures($('live-overlay'), f.width, f.height, f.keypoints, f.tracked, []);
  img.src = '/api/live/image.jpg?i=' + f.index;
}

// `summary`: the keyframe as the scene lists it (its residual against the scan's markers).
export async function showKeyframe(id, registration, summary) {
  $('keyframe').hidden = false;
  $('kf-id').textContent = id;
  const r = await fetch('/api/keyframe/' + id);
  if (!r.ok) { $('kf-info').textContent = 'keyframe ' + id + ' is no longer in the map'; return; }
  const k = await r.json();
  const tracked = [...k.tracked].filter((c) => c === '1').length;
  $('kf-info').innerHTML = `t <b>${k.t.toFixed(3)}</b> keypoints <b>${k.keypoints.length / 2}</b> ` +
    `with a map point <b id="kf-tracked">${tracked}</b> markers <b id="kf-markers">${k.markers.map((m) => m.id).join(', ') || 'none'}</b><br>` +
    `reprojection RMS <b>${fmt(k.residual_px)}</b> px` +
    (summary && summary.marker_residual_px >= 0 ? ` &middot; scan marker corners <b id="kf-marker-residual">${fmt(summary.marker_residual_px)}</b> px` : '') +
    ` &middot; position <b>${k.pose.slice(4).map((v) => v.toFixed(3)).join(', ')}</b>`;
  const img = $('kf-image');
  const draw = () => drawFeatures($('kf-overlay'), k.width, k.height, k.keypoints, k.tracked, k.markers);
  img.onload = () => { img.dataset.loaded = id; draw(); };
  img.onerror = () => {
    // No image source (coloc view without --sequence): the features on a blank frame.
    img.removeAttribute('src');
    img.style.height = (400 * k.height / k.width) + 'px';
    img.dataset.loaded = 'none';
    draw();
  };
  img.style.height = '';
  img.src = `/api/keyframe/${id}/image.jpg`;
  const report = $('kf-report');
  report.innerHTML = '';
  if (!registration) return;
  const refined = registration.registration && registration.registration.pointcloud
    ? registration.registration.pointcloud.per_keyframe.find((x) => x.id === id) : null;
  if (refined) {
    report.innerHTML = `point-cloud refinement: <b>${refined.reason}</b>, ${refined.inliers}/${refined.matches} inliers, ` +
      `moved ${fmt(100 * refined.correction_m)} cm ${fmt(refined.correction_deg)} deg, RMS ${fmt(refined.rms_reprojection_px)} px`;
  }
  for (const fig of registration.report.filter((x) => x.keyframe === id)) {
    report.insertAdjacentHTML('beforeend', `<div class="figure">before (markers)<img src="${fig.markers}"></div>` +
      `<div class="figure">after (point cloud)<img src="${fig.pointcloud}"></div>`);
  }
}

export async function showRegistration() {
  const r = await fetch('/api/registration');
  if (!r.ok) return null;
  const reg = await r.json();
  if (!reg || (!reg.registration && reg.report.length === 0)) return reg;
  $('registration').hidden = false;
  const j = reg.registration;
  if (j) {
    let s = `level <b>${j.level}</b>, rough: <b>${j.rough.inliers}</b> markers, RMS <b>${fmt(100 * j.rough.rms_m)}</b> cm`;
    if (j.markers) s += `<br>marker BA: corners <b>${fmt(j.markers.marker_rms_px[0])} &rarr; ${fmt(j.markers.marker_rms_px[1])}</b> px, points <b>${fmt(j.markers.point_rms_px[0])} &rarr; ${fmt(j.markers.point_rms_px[1])}</b> px`;
    if (j.pointcloud) s += `<br>point cloud: <b>${j.pointcloud.accepted}/${j.pointcloud.keyframes}</b> keyframes accepted, median correction <b>${fmt(100 * j.pointcloud.median_correction_m)}</b> cm`;
    $('reg-summary').innerHTML = s;
    const ba = new Map(((j.markers && j.markers.markers) || []).map((m) => [m.id, m]));
    let rows = '<tr><th>marker</th><th>keyframes</th><th>rough cm</th><th>BA px before</th><th>after</th><th></th></tr>';
    for (const m of j.rough.markers) {
      const b = ba.get(m.id);
      rows += `<tr><td>${m.id}</td><td>${m.keyframes}</td><td>${fmt(100 * m.residual_m)}</td>` +
        `<td>${b ? fmt(b.rms_px[0]) : '-'}</td><td>${b ? fmt(b.rms_px[1]) : '-'}</td>` +
        `<td>${!m.consistent ? 'inconsistent' : b && b.rejected ? 'rejected' : ''}</td></tr>`;
    }
    $('reg-markers').innerHTML = rows;
  }
  const figs = $('reg-figures');
  for (const fig of reg.report) {
    figs.insertAdjacentHTML('beforeend', `<div class="figure">keyframe ${fig.keyframe}: before (markers) / after (point cloud)` +
      `<img src="${fig.markers}"><img src="${fig.pointcloud}"></div>`);
  }
  return reg;
}
