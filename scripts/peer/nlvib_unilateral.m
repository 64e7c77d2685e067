% Peer reference for tests/peer_nlvib_cli.rs: the forced response of NLvib's own example
% EXAMPLES/03_twoDOFoscillator_unilateralSpring (the 2-DOF chain with a unilateral spring),
% computed with NLvib's harmonic balance (HB_residual, analysis 'frf') and its continuation
% (solve_and_continue), written as tests/data/peer/nlvib_unilateral.csv. See docs/PEER_NLVIB.md.
%
% NLvib: https://github.com/maltekrack/NLvib, commit 69598c5e85a5967d1931d3560e5c3d7ab968596f
% (2024-02-22, "Update beam_cubicSpring_NM1.m"), NLvib version 1.3, used unmodified. Run with
% GNU Octave 7.3 (Debian 12 package `octave`), from the repository root:
%
%   git clone https://github.com/maltekrack/NLvib /tmp/NLvib
%   git -C /tmp/NLvib checkout 69598c5e85a5967d1931d3560e5c3d7ab968596f
%   NLVIB=/tmp/NLvib octave --no-gui -q scripts/peer/nlvib_unilateral.m
%
% (about 1 minute). Optional arguments: the output CSV (default
% tests/data/peer/nlvib_unilateral.csv).
%
% The only difference from the example's HB call: the fsolve options are passed explicitly
% (solve_and_continue's default `optimset(@fsolve)` is MATLAB syntax that Octave refuses), with
% tighter tolerances (TolFun = TolX = 1e-12 instead of 1e-6), and the continuation is finer
% (ds = dsmax = 0.003, dsmin = 1e-6, errmax = 30, stepmax = 20000) so that the stored curve can be
% interpolated; the range is widened to [0.48, 0.83] rad/s to cover nlmodes' last point.

1;  % a script file, not a function file

% Largest value over the period of DOF 1 (q1 - gap > 0: the spring is compressed somewhere).
function m = max_q1(X, n, H, N)
  tau = 2*pi*(0:N-1)'/N;
  q = X(1)*ones(N,1);
  for h = 1:H
    q = q + X(n+(h-1)*2*n+1)*cos(h*tau) + X(2*n+(h-1)*2*n+1)*sin(h*tau);
  end
  m = max(q);
end

nlvib = getenv('NLVIB');
if isempty(nlvib)
  error('set NLVIB to the NLvib checkout (see the header)');
end
addpath(fullfile(nlvib, 'SRC'));
addpath(fullfile(nlvib, 'SRC', 'MechanicalSystems'));
args = argv();
if numel(args) >= 1
  out = args{1};
else
  out = fullfile('tests', 'data', 'peer', 'nlvib_unilateral.csv');
end

%% The system: the example's own parameters
mi = [1 1];             % masses
ki = [0 1 1];           % springs: K = [2 -1; -1 1]... see below
di = .03*ki;            % dampers: D = 0.03 K
Fex1 = [0;.1];          % fundamental excitation force harmonic (cosine), on DOF 2
% Unilateral spring on DOF 1: f = 100 (q1 - 1)_+ (gap 1)
nonlinear_elements = struct('type','unilateralSpring',...
    'stiffness',1e2,'gap',1,'force_direction',[1;0]);
oscillator = ChainOfOscillators(mi,di,ki,nonlinear_elements,Fex1);
n = oscillator.n;
% ChainOfOscillators: K = [1 -1; -1 2], D = 0.03 K, M = I (DOF 1 is tied to DOF 2 only,
% DOF 2 to DOF 1 and the ground).

%% Harmonic balance, as in the example (H = 21, N = 2^10), in two pieces that meet at the
% grazing corner near Om = 0.582 (where the upper contact branch ends on the linear branch; a
% single continuation creeps there at the smallest step): A from the top of the range down to
% within 1e-4 of grazing on the upper branch, B from the bottom up the linear branch to grazing.
H = 21;
N = 2^10;
gap = 1;
Solopt = optimset('Display','off','Jacobian','on','MaxIter',50, ...
    'TolFun',1e-12,'TolX',1e-12);
ds = .003;
pieces = {};
for piece = 1:2
  if piece == 1
    Om_s = .83; Om_e = .48;
    stop = @(X) X(end) < .6 && max_q1(X, n, H, N) < gap + 1e-4;
  else
    Om_s = .48; Om_e = .83;
    stop = @(X) max_q1(X, n, H, N) > gap;
  end
  Q1 = (-Om_s^2*oscillator.M + 1i*Om_s*oscillator.D + oscillator.K)\Fex1;
  y0 = zeros((2*H+1)*n,1);
  y0(n+(1:2*n)) = [real(Q1);-imag(Q1)];
  Sopt = struct('Dscale',[ones(size(y0));Om_s],'dsmin',1e-5,'dsmax',ds, ...
      'errmax',30,'stepmax',20000,'termination_criterion',{{stop}});
  pieces{piece} = solve_and_continue(y0, ...
      @(X) HB_residual(X,oscillator,H,N,'frf'), Om_s,Om_e,ds,Sopt,{},Solopt);
end
% Piece B ends at its first point in contact: drop it, then append B reversed to A.
B = pieces{2};
X = [pieces{1}, fliplr(B(:,1:end-1))];
Om = X(end,:);
Q = X(1:end-1,:);
% q(t) = Q0 + sum_h Qc_h cos(h Om t) + Qs_h sin(h Om t); X = [Q0; Qc_1; Qs_1; Qc_2; ...]
a1 = hypot(Q(n+1,:), Q(2*n+1,:));   % first harmonic of DOF 1 (the contact DOF)
a2 = hypot(Q(n+2,:), Q(2*n+2,:));   % first harmonic of DOF 2 (the forced DOF)
m1 = Q(1,:);                        % mean of DOF 1
R = zeros(size(Om));
for k = 1:numel(Om)
  R(k) = norm(HB_residual(X(:,k),oscillator,H,N,'frf'));
end

gq = zeros(size(Om));
for k = 1:numel(Om)
  gq(k) = max_q1(X(:,k), n, H, N) - gap;
end

%% Folds and peak. The sampled (N = 2^10) penalty problem has a kink wherever a time sample
% enters or leaves contact, and its curve wiggles on a small scale (Om steps back by up to 1e-5
% between neighbouring points on the contact branches): a fold is where Om turns and then
% retreats by more than 1e-4 rad/s; its Om is refined by the parabola through the three points
% around the extremum.
folds = [];
k0 = 1;
dir = sign(Om(2) - Om(1));
for k = 2:numel(Om)
  if dir*(Om(k) - Om(k0)) > 0
    k0 = k;
  elseif dir*(Om(k0) - Om(k)) > 1e-4
    c = polyfit([-1 0 1], Om(k0-1:k0+1), 2);
    folds(end+1,:) = [polyval(c, -c(2)/(2*c(1))), a1(k0)];
    dir = -dir;
    k0 = k;
  end
end
[~, kp] = max(a1);
c = polyfit([-1 0 1], a1(kp-1:kp+1), 2);
cw = polyfit([-1 0 1], Om(kp-1:kp+1), 2);
sp = -c(2)/(2*c(1));
printf('%d points (%d + %d), ',numel(Om),columns(pieces{1}),columns(B)-1);
printf('max |R| = %.2e, peak a1 = %.6f at Om = %.6f (largest point %.6f at %.6f)\n', ...
    max(R), polyval(c,sp), polyval(cw,sp), a1(kp), Om(kp));
for k = 1:rows(folds)
  printf('fold at Om = %.6f (a1 = %.4f)\n', folds(k,1), folds(k,2));
end

%% Write the curve, in continuation order
fid = fopen(out, 'w');
fprintf(fid, ['# NLvib (github.com/maltekrack/NLvib @ 69598c5e85a5967d1931d3560e5c3d7ab968596f, ' ...
    'HB_residual frf + solve_and_continue) in GNU Octave %s, scripts/peer/nlvib_unilateral.m: ' ...
    'EXAMPLES/03_twoDOFoscillator_unilateralSpring, M = I, K = [1 -1; -1 2], D = 0.03 K, ' ...
    'f = [0; 0.1] cos(Om t), unilateral spring 100 (q1 - 1)_+, H = %d, N = %d; ' ...
    'a1_dof* = first-harmonic amplitude sqrt(c1^2 + s1^2), mean_dof1 = zeroth harmonic, ' ...
    'max_q1_minus_gap = max over the period of q1 - 1 (> 0: in contact), residual = |R| of HB_residual; two continuations joined at the grazing corner near 0.582 rad/s\n'], version(), H, N);
fprintf(fid, 'omega_rad_s,a1_dof1,a1_dof2,mean_dof1,max_q1_minus_gap,residual\n');
fprintf(fid, '%.12e,%.12e,%.12e,%.12e,%.6e,%.2e\n', [Om; a1; a2; m1; gq; R]);
fclose(fid);
printf('wrote %s\n', out);
