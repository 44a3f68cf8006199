function [beam, om_lin, itip] = ecl_beam_model(F, beta)
% ECL_BEAM_MODEL  The ECL cantilever beam of nnm's `CantileverBeam` defaults
% (crates/nnm/src/model/beams.rs) built with NLvib's own classes: a clamped-free
% Euler-Bernoulli beam 0.7 m long, 14 x 14 mm, E = 205 GPa, rho = 7800 kg/m^3,
% 19 Hermite elements (20 nodes, 38 dofs after clamping), a cubic spring
% 6e9 * w_tip^3 N from the tip's transverse displacement to ground,
% Rayleigh damping D = beta*K and the force F*cos(Om*t) on the tip's
% transverse dof.
%
% NLvib orders the dofs as nnm does (w, theta per node, node 1 clamped and
% removed), so the tip's transverse displacement is dof 37 here (1-based),
% dof 36 in nnm (0-based).
len = 0.7; height = 0.014; thickness = 0.014; E = 2.05e11; rho = 7800;
n_nodes = 20;
beam = FE_EulerBernoulliBeam(len, height, thickness, E, rho, 'clamped-free', n_nodes);
add_nonlinear_attachment(beam, n_nodes, 'trans', 'cubicSpring', 'stiffness', 6e9);
beam.D = beta*beam.K;
add_forcing(beam, n_nodes, 'trans', F);
itip = find_coordinate(beam, n_nodes, 'trans');
% Linear frequencies: the dense generalized eigensolver alone is accurate to only
% ~1e-10 here (the stiffness spans nine decades), so each of the lowest four is
% refined by shifted inverse iteration and a Rayleigh quotient, which is accurate
% to the square of the mode shape's error.
lam = sort(eig(beam.K, beam.M));
om_lin = sqrt(lam);
for k = 1:min(4, beam.n)
    s0 = 0.999*lam(k);
    A = beam.K - s0*beam.M;
    phi = ones(beam.n, 1);
    for it = 1:30
        phi = A\(beam.M*phi); phi = phi/norm(phi);
    end
    om_lin(k) = sqrt((phi'*beam.K*phi)/(phi'*beam.M*phi));
end
end
