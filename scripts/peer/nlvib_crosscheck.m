% Cross-check of nlmodes' forced orbits with NLvib's own equations (docs/PEER_NLVIB.md): for every
% orbit of an nlmodes frf.json of the system of scripts/peer/nlvib_unilateral.m (as run by
% tests/peer_nlvib_cli.rs: H = 21, 1024 samples), NLvib's HB residual at that orbit, then NLvib's
% Newton (fsolve with NLvib's analytical Jacobian) at the same W from it, and the change of the
% first harmonics. NLvib as in nlvib_unilateral.m (commit 69598c5e85a5967d1931d3560e5c3d7ab968596f).
%
%   NLVIB=/tmp/NLvib octave --no-gui -q scripts/peer/nlvib_crosscheck.m OUT/frf.json [table.txt]
%
% nlmodes' coefficients per coordinate are [c0, a1, b1, a2, b2, ...] with
% q = c0 + sum a_h cos(h W t) + b_h sin(h W t); NLvib's X = [Q0; Qc_1; Qs_1; ...] (all
% coordinates per block) with the same meaning.
1;
function [R,dR] = fixed_frequency(Y,W,osc,H,N)
  [R,dRf] = HB_residual([Y;W],osc,H,N,'frf');
  dR = dRf(:,1:end-1);
end

nlvib = getenv('NLVIB');
if isempty(nlvib)
  error('set NLVIB to the NLvib checkout');
end
addpath(fullfile(nlvib, 'SRC'));
addpath(fullfile(nlvib, 'SRC', 'MechanicalSystems'));
args = argv();
mi = [1 1]; ki = [0 1 1]; di = .03*ki; Fex1 = [0;.1];
ne = struct('type','unilateralSpring','stiffness',1e2,'gap',1,'force_direction',[1;0]);
osc = ChainOfOscillators(mi,di,ki,ne,Fex1);
n = 2; H = 21; N = 2^10;
d = jsondecode(fileread(args{1}));
orb = d.curves(1).orbits;
K = numel(orb);
opt = optimset('Display','off','Jacobian','on','MaxIter',100,'TolFun',1e-14,'TolX',1e-14);
out = zeros(K,8);
for k = 1:K
  W = orb(k).omega;
  c = orb(k).coefficients;   % coordinates x (2 H + 1); coordinates 3, 4 are the pads
  X = zeros(n*(2*H+1),1);
  X(1:n) = c(1:n,1);
  for h = 1:H
    X(n+(h-1)*2*n+(1:n)) = c(1:n,2*h);
    X(2*n+(h-1)*2*n+(1:n)) = c(1:n,2*h+1);
  end
  R0 = HB_residual([X;W],osc,H,N,'frf');
  [Xs,~,info] = fsolve(@(Y) fixed_frequency(Y,W,osc,H,N), X, opt);
  a1n = hypot(X(n+1),X(2*n+1)); a2n = hypot(X(n+2),X(2*n+2));
  a1p = hypot(Xs(n+1),Xs(2*n+1)); a2p = hypot(Xs(n+2),Xs(2*n+2));
  out(k,:) = [W a1n a1p a2n a2p norm(R0) norm(Xs-X)/norm(X) info];
end
if numel(args) >= 2
  save('-ascii', args{2}, 'out');   % W, a1 nlmodes, a1 NLvib, a2 nlmodes, a2 NLvib, |R|, |dX|/|X|, info
end
printf(['%d orbits: largest NLvib residual at nlmodes'' orbits %.2e; NLvib Newton from them: ' ...
    'largest |dX|/|X| %.2e, largest relative change of a1 (DOF 1) %.2e, of a1 (DOF 2) %.2e; ' ...
    'fsolve exit flags >= %d\n'], K, max(out(:,6)), max(out(:,7)), ...
    max(abs(out(:,2)./out(:,3)-1)), max(abs(out(:,4)./out(:,5)-1)), min(out(:,8)));
