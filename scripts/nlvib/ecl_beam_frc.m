% ECL_BEAM_FRC  NLvib's harmonic balance on the forced, damped ECL cantilever beam:
% the reference and the timing for nnm's issue 27, item 5.
%
%   M q'' + beta K q' + K q + 6e9 w_tip^3 e_tip = F cos(Om t) e_tip,
%   Om from 0.9 om1 to 1.3 om1 (om1 the first linear frequency).
%
% Run from this directory with NLvib's SRC on the path (see README.md):
%   NLVIB=/path/to/NLvib octave-cli ecl_beam_frc.m
% Environment (defaults in brackets): F [0.01] N, BETA [1e-5] s, H [7], DS [0.5] rad/s
% (NLvib's step, in units of Om), TOL [1e-10] (fsolve's TolFun and TolX), HREF [15].
1;  % a script file: its functions come first, as Octave requires

function v = ifelse_env(name, default)
    s = getenv(name);
    if isempty(s), v = default; else, v = str2double(s); end
end

function p = tip_peak(X, n, itip)
    % max over the period of |w_tip(t)|: sampled, then Newton on dw/dtau = 0.
    H = (numel(X) - 1 - n)/(2*n);
    c = [X(itip); X(n+itip:2*n:end-1)]; s = [0; X(2*n+itip:2*n:end-1)];
    h = (0:H)';
    w = @(t) sum(c.*cos(h*t) + s.*sin(h*t), 1);
    tau = linspace(0, 2*pi, 4097); tau(end) = [];
    [~, j] = max(abs(w(tau))); t = tau(j);
    for it = 1:8
        d1 = sum(h.*(-c.*sin(h*t) + s.*cos(h*t)));
        d2 = sum(-h.^2.*(c.*cos(h*t) + s.*sin(h*t)));
        t = t - d1/d2;
    end
    p = abs(w(t));
end

function [Xbest, Ombest] = refine(X, i, n, itip, res, objective)
    % Natural parameter: the tip's first-harmonic cosine or sine, whichever changes
    % more between the neighbours of point i; maximize objective over it.
    cand = [n+itip, 2*n+itip];
    [~, j] = max(abs(X(cand, i+1) - X(cand, i-1))); k = cand(j);
    a = X(k, i-1); b = X(k, i+1);
    guess = X(:, i);
    f = @(p) -objective(solve_at(p, k, guess, res));
    pbest = fminbnd(f, min(a, b), max(a, b), optimset('TolX', 1e-13*max(abs([a b]))));
    Xbest = solve_at(pbest, k, guess, res); Ombest = Xbest(end);
end

function Y = solve_at(p, k, Y, res)
    % Newton on R(Y) = 0 with Y(k) = p fixed and Om free.
    Y(k) = p;
    free = setdiff(1:numel(Y), k);
    scale = [max(abs(Y(1:end-1)))*ones(numel(Y)-1, 1); abs(Y(end))];
    for it = 1:30
        [R, dR] = res(Y);
        step = dR(:, free)\R;
        Y(free) = Y(free) - step;
        if norm(step./scale(free)) < 1e-13, break; end
    end
end

nlvib = getenv('NLVIB'); if isempty(nlvib), nlvib = 'NLvib'; end
addpath(fullfile(nlvib, 'SRC')); addpath(fullfile(nlvib, 'SRC', 'MechanicalSystems'));
env = @(name, default) ifelse_env(name, default);
F = env('F', 0.01); beta = env('BETA', 1e-5); H = env('H', 7); ds = env('DS', 0.5);
tol = env('TOL', 1e-10); Href = env('HREF', 15);

[beam, om, itip] = ecl_beam_model(F, beta);
n = beam.n;
printf('Octave %s, NLvib at %s\n', OCTAVE_VERSION, nlvib);
printf('%d dofs, tip transverse dof %d (1-based; nnm: %d)\n', n, itip, itip-1);
printf('linear frequencies (rad/s): %.12f %.12f %.12f %.12f\n', om(1:4));
printf('F = %g N, beta = %g s, H = %d, N = 4H+1, ds = %g, TolFun = TolX = %g\n', F, beta, H, ds, tol);

Om_s = 0.9*om(1); Om_e = 1.3*om(1);
printf('Om from %.10f to %.10f rad/s\n', Om_s, Om_e);

% NLvib's FRF set-up (its example 02): the linear response at Om_s as the first
% guess; cosine and sine harmonics as unknowns, q = Re(Q exp(i Om t)) so Q = Qc - i Qs.
Q1 = (-Om_s^2*beam.M + 1i*Om_s*beam.D + beam.K)\beam.Fex1;
y0 = zeros((2*H+1)*n, 1); y0(n+(1:2*n)) = [real(Q1); -imag(Q1)];
% Displacements scaled by the largest linear response over the sweep (at om1), as nnm
% scales them; Om by Om_s, as NLvib's examples do.
Qr = (-om(1)^2*beam.M + 1i*om(1)*beam.D + beam.K)\beam.Fex1;
qscl = max(abs(Qr));
Sopt = struct('Dscale', [qscl*ones(size(y0)); Om_s]);
% NLvib's own solver options, optimset(@fsolve,...) spelled as Octave accepts it, and
% tolerances tightened: Octave's fsolve stops at norm(R) <= TolFun*numel(x)*norm(x),
% ~1e-3 with the default 1e-6, which lets the squared arclength equation go unmet.
Solopt = optimset(optimset('fsolve'), 'Display', 'off', 'Jacobian', 'on', 'MaxIter', 50, ...
                  'TolFun', tol, 'TolX', tol);
res = @(X) HB_residual(X, beam, H, 4*H+1, 'FRF');

% Warm-up (parsing, first calls), then the timed continuation (NLvib prints each point).
Sw = Sopt; Sw.stepmax = 3;
solve_and_continue(y0, res, Om_s, Om_e, ds, Sw, {}, Solopt);
t0 = tic;
[X, Solinfo] = solve_and_continue(y0, res, Om_s, Om_e, ds, Sopt, {}, Solopt);
t_cont = toc(t0);
Om = X(end, :);
printf('\nNLvib HB continuation: %d points, %d residual evaluations, %.2f s (%.1f ms/point)\n', ...
       size(X, 2), Solinfo.FCtotal, t_cont, 1e3*t_cont/size(X, 2));
printf('last point at %.6f om1\n', Om(end)/om(1));

% Folds: Om turns along the curve. Each is located by a natural parametrization in the
% tip's first-harmonic coordinate that changes most there (regular through the fold),
% maximizing/minimizing Om over it with fminbnd, each point solved by Newton to 1e-12.
d = diff(Om); ifold = find(d(1:end-1).*d(2:end) < 0) + 1;
pk = arrayfun(@(i) tip_peak(X(:, i), n, itip), 1:size(X, 2));
[~, ipk] = max(pk);
printf('folds near Om/om1 = %s; largest sampled peak %.6e m at %.6f om1\n', ...
       num2str(Om(ifold)/om(1), 8), pk(ipk), Om(ipk)/om(1));

for Hx = unique([H Href])
    if Hx == H
        resx = res; Xx = X;
    else
        resx = @(X) HB_residual(X, beam, Hx, 4*Hx+1, 'FRF');
        Xx = zeros((2*Hx+1)*n+1, size(X, 2));
        Xx(1:(2*H+1)*n, :) = X(1:end-1, :); Xx(end, :) = X(end, :);
    end
    printf('\nH = %d (N = %d):\n', Hx, 4*Hx+1);
    for i = ifold
        [Xf, Omf] = refine(Xx, i, n, itip, resx, @(Y) sign(d(i-1))*Y(end));
        printf('  fold  Om = %.10f rad/s = %.10f om1, peak |w_tip| %.10e m\n', ...
               Omf, Omf/om(1), tip_peak(Xf, n, itip));
    end
    [Xp, ~] = refine(Xx, ipk, n, itip, resx, @(Y) tip_peak(Y, n, itip));
    printf('  peak  |w_tip| = %.10e m at Om = %.10f rad/s = %.10f om1\n', ...
           tip_peak(Xp, n, itip), Xp(end), Xp(end)/om(1));
end

