% Reference γ for host/synth (H∞ synthesis, mixed sensitivity) from an
% independent implementation: Octave's control package, whose hinfsyn and
% mixsyn call SLICOT (SB10AD, γ iteration). Writes
% tests/host/synth/fixtures/synth_hinf.json, read by
% tests/host/synth/test_mixsyn.cpp. Run from the repository root:
%
%   octave-cli tools/ref/synth_hinf.m
%
% Needs Debian's octave and octave-control (NOT installed by tools/setup:
% only this generator needs them; the tests read the committed fixture).
% Unlike the tools/ref/*.py generators, golden_up_to_date does not rerun it.
%
% Each problem's models are written to the fixture as zeros/poles/gain (the
% model-file format), so the C++ side realises the very same models.
% 'tolgam' 1e-6: the default 0.01 stops about 1 % above the optimum.
%
% Ill-scaled problems: Octave gets every model with its frequency axis
% scaled, s = w0 s~ (roots / w0, gain * w0^(#zeros - #poles)); the H∞ norm,
% and so γ, is invariant under this. Unscaled, SB10AD fails on Ahmad2020's
% G(s) with H_y (poles from 3.78 to 7.5e7 rad/s). The C++ side gets the
% models unscaled (its hinfsyn scales by itself).
pkg load control
1;

function m = mdl(z, p, k)
  m.z = z(:); m.p = p(:); m.k = k;
end

function m = tf_mdl(num, den)
  m = mdl(roots(num), roots(den), num(find(num, 1)) / den(find(den, 1)));
end

function m = series_mdl(a, b)
  m = mdl([a.z; b.z], [a.p; b.p], a.k * b.k);
end

% Second-order mode wn^2 / (s^2 + 2 zeta wn s + wn^2).
function m = mode_mdl(wn, zeta)
  m = tf_mdl(wn^2, [1, 2 * zeta * wn, wn^2]);
end

function m = scaled(m, w0)
  m.k = m.k * w0^(numel(m.z) - numel(m.p));
  m.z = m.z / w0; m.p = m.p / w0;
end

function s = roots_json(r)
  s = "[";
  for i = 1:numel(r)
    if i > 1, s = [s ", "]; end
    s = [s sprintf("[%.17g, %.17g]", real(r(i)), imag(r(i)))];
  end
  s = [s "]"];
end

function s = mdl_json(m)
  if isempty(m)
    s = "null";
  else
    s = sprintf("{\"zeros\": %s, \"poles\": %s, \"gain\": %.17g}", roots_json(m.z), roots_json(m.p), m.k);
  end
end

function sys = to_ss(m)
  if isempty(m), sys = []; else, sys = ss(zpk(m.z, m.p, m.k)); end
end

two_pi = 2 * pi;
% Performance weight on S: |W1| = 1/A at low frequency, 1/M at high, crossing 1 near wb.
w1_std = @(M, wb, A) mdl(-M * wb, -wb * A, 1 / M);

P = {};
% 1. One lightly damped mode (zeta 0.01 at 300 Hz): 3 states.
P{end+1} = struct("name", "one_mode", "desc", "mode at 300 Hz, zeta 0.01; W1 (30 Hz), W2 = 0.1", ...
  "g", mode_mdl(two_pi * 300, 0.01), "w1", w1_std(2, two_pi * 30, 1e-3), "w2", mdl([], [], 0.1), "w3", [], "w0", 1);
% 2. Three lightly damped modes with W3 (proper: a far pole): 8 states.
g3 = series_mdl(series_mdl(mode_mdl(two_pi * 300, 0.01), mode_mdl(two_pi * 1200, 0.005)), mode_mdl(two_pi * 2500, 0.02));
P{end+1} = struct("name", "three_modes", "desc", "modes at 300, 1200, 2500 Hz (zeta 0.01, 0.005, 0.02); W1 (20 Hz), W2 = 0.05, W3 proper", ...
  "g", g3, "w1", w1_std(2, two_pi * 20, 1e-3), "w2", mdl([], [], 0.05), ...
  "w3", mdl(-two_pi * 500, -two_pi * 50000, 100 * 0.5), "w0", 1);
% 3. Janaideh2016's D(s): non-minimum phase (RHP zeros 1.07e4 ... 1.22e5 rad/s), 9 states.
jd = mdl([1.22e5; -2.99e4; 2.776e4; 1.07e4; -1430; roots([1, 4.3e4, 3.2e9])], ...
         [roots([1, 925, 4.59e5]); roots([1, 55, 1.4e7]); roots([1, 1.54e4, 4e9]); roots([1, 964, 3.95e9])], ...
         -20.7 / 3.2e9 * 3.2e9);
jd.k = -20.7;
P{end+1} = struct("name", "janaideh2016_D", "desc", "Janaideh2016 D(s), NMP; W1 (50 Hz), W2 = 0.1", ...
  "g", jd, "w1", w1_std(2, two_pi * 50, 1e-3), "w2", mdl([], [], 0.1), "w3", [], "w0", 1e4);
% 4. Ahmad2020's G(s) (coefficients 1e0 ... 1e23) with the published H_e and H_y, W2 = 0.01: 9 states.
ga = tf_mdl([2.01e11, 4.74e15, 2.76e19, 1.84e23], [1, 1.08e4, 2.95e8, 1.98e12, 1.65e16, 5.79e19, 2.05e23]);
he = tf_mdl([0.5, 1260], [1, 3.78]);
% H_y as published (eps_y 1e-4) is 1e8 at high frequency and 0.44 at DC: in
% C1'C1 its low-frequency part is 1e-16 of the whole and lost to rounding,
% on both sides (Octave: no admissible controller; host/synth: refused, the
% controller misses γ). With eps_y 1e-2 (poles at 7.5e5 rad/s, still 50
% times above G's highest mode) the gain spans 1e4 and the problem is solvable.
hy = series_mdl(tf_mdl([1, 5000], [1e-2, 7500]), tf_mdl([1, 5000], [1e-2, 7500]));
P{end+1} = struct("name", "ahmad2020_G", "desc", "Ahmad2020 G(s) with H_e (W1), W2 = 0.01, H_y with eps_y 1e-2 (W3); Octave given s = 1e4 s~", ...
  "g", ga, "w1", he, "w2", mdl([], [], 0.01), "w3", hy, "w0", 1e4);
hy_pub = series_mdl(tf_mdl([1, 5000], [1e-4, 7500]), tf_mdl([1, 5000], [1e-4, 7500]));
P{end+1} = struct("name", "ahmad2020_G_published_Hy", "desc", "as ahmad2020_G with the published H_y (eps_y 1e-4): gain 0.44 ... 1e8, numerically out of reach", ...
  "g", ga, "w1", he, "w2", mdl([], [], 0.01), "w3", hy_pub, "w0", 1e4);
% 5. Specifications no controller meets: Janaideh2016's D(s) with |S| pushed down
%    beyond its RHP zeros (W1 crossing at 5 kHz): γ > 1.
P{end+1} = struct("name", "infeasible_nmp", "desc", "Janaideh2016 D(s), W1 crossing at 5 kHz beyond the RHP zeros: gamma > 1", ...
  "g", jd, "w1", w1_std(1.5, two_pi * 5000, 1e-4), "w2", mdl([], [], 0.1), "w3", [], "w0", 1e4);
% 6. 14 states: five modes (10), second-order W1, first-order W2 and W3.
g5 = series_mdl(g3, series_mdl(mode_mdl(two_pi * 4000, 0.01), mode_mdl(two_pi * 7000, 0.03)));
w1sq = series_mdl(w1_std(sqrt(2), two_pi * 20, 1e-2), w1_std(sqrt(2), two_pi * 20, 1e-2));
P{end+1} = struct("name", "order14", "desc", "five modes 300 Hz ... 7 kHz, W1 second order, W2 first order (rising), W3 proper", ...
  "g", g5, "w1", w1sq, "w2", mdl(-two_pi * 2000, -two_pi * 200000, 100 * 0.05), ...
  "w3", mdl(-two_pi * 800, -two_pi * 80000, 100 * 0.3), "w0", 1e4);
% 7. No W2 and a strictly proper G: D12 = 0, both sides must refuse.
P{end+1} = struct("name", "d12_rank", "desc", "no W2, strictly proper G: D12 = 0", ...
  "g", mode_mdl(two_pi * 300, 0.01), "w1", w1_std(2, two_pi * 30, 1e-3), "w2", [], "w3", [], "w0", 1);

out = "{\n \"generator\": \"tools/ref/synth_hinf.m (Octave control package: mixsyn -> hinfsyn -> SLICOT SB10AD)\",\n";
out = [out sprintf(" \"octave\": \"%s\",\n \"control\": \"%s\",\n \"tolgam\": 1e-6,\n \"problems\": [\n", OCTAVE_VERSION, pkg("describe", "control"){1}.version)];
for i = 1:numel(P)
  p = P{i};
  w0 = p.w0;
  G = to_ss(scaled(p.g, w0));
  W1 = to_ss(scaled(p.w1, w0));
  if isempty(p.w2), W2 = []; else, W2 = to_ss(scaled(p.w2, w0)); end
  if isempty(p.w3), W3 = []; else, W3 = to_ss(scaled(p.w3, w0)); end
  err = "";
  gam = NaN;
  nstates = NaN;
  try
    [K, N, gam] = mixsyn(G, W1, W2, W3, "tolgam", 1e-6);
    nstates = size(K.a, 1);
    gn = norm(N, inf);
    if !isfinite(gam)
      err = sprintf("gamma %g: no admissible controller found (closed loop not stable)", gam);
    end
    printf("%-16s gamma %.9g (||N|| %.9g), K order %d\n", p.name, gam, gn, nstates);
  catch e
    err = e.message;
    printf("%-16s error: %s\n", p.name, err);
  end
  out = [out sprintf("  {\"name\": \"%s\", \"description\": \"%s\", \"octave_w0_rad_s\": %.17g,\n", p.name, p.desc, w0)];
  out = [out sprintf("   \"plant\": %s,\n   \"w1\": %s,\n   \"w2\": %s,\n   \"w3\": %s,\n", ...
                     mdl_json(p.g), mdl_json(p.w1), mdl_json(p.w2), mdl_json(p.w3))];
  if isempty(err)
    out = [out sprintf("   \"octave_gamma\": %.17g, \"octave_error\": null}", gam)];
  else
    out = [out sprintf("   \"octave_gamma\": null, \"octave_error\": \"%s\"}", strrep(strtrim(err), "\"", "'"))];
  end
  if i < numel(P), out = [out ",\n"]; else, out = [out "\n"]; end
end
out = [out " ]\n}\n"];
f = fopen("tests/host/synth/fixtures/synth_hinf.json", "w");
fputs(f, out);
fclose(f);
