#!/usr/bin/python3
"""1D linear model of the PD-SPH interface of check.py (issue 8, fourth pass; README there).
tlpd sum form (horizon 3, constant influence, partial volumes, 002 hourglass term, E = 1 GPa, nu = 0),
linearised about rest, coupled through the owned pair terms to an SPH fluid (cubic spline, fluid h in
spacings); leapfrog; the cos^2 pulse and the peak measure of check.py against the exact incident.
Prints, per fluid h: T and R errors (%) at Z2/Z1 = 0.354, then at 2.83.
mode: None (kernel gradient at the fluid h: the former rule), "pd2" (pair_weight bond), "ideal"
(reactions with minus the PD free-surface profile c_k, not reachable by an interaction), others:
variants of the README. Usage: linear_model.py "{'hs': [1.3, 2.0], 'mode': 'pd2'}"
"""
import numpy as np, sys
def dfk(q):
    q=np.abs(q)
    return np.where(q<1, -3*q+2.25*q*q, np.where(q<2, -0.75*(2-q)**2, 0.0))
E, rho1 = 1e9, 2000.0
def solid_matrix(Ns, dx, hor=3.0, chg=0.01):
    xs = (np.arange(-Ns,0)+0.5)*dx
    X = xs[None,:]-xs[:,None]          # X_ij = x_j - x_i
    r = np.abs(X); delta=hor*dx
    beta = np.clip((delta+0.5*dx-r)/dx, 0, 1); np.fill_diagonal(beta,0)
    A = beta*dx                        # w beta V_j
    K = (A*X*X).sum(1)
    m1 = (A*X).sum(1)
    C = 2*chg*E/K
    # F_i - 1 = sum_j A_ij (u_j - u_i) X_ij / K_i  -> matrix Fm: (F-1) = Fm u
    Fm = (A*X)/K[:,None]; Fm[np.diag_indices(Ns)] -= m1/K
    # force density f_i = sum_j A_ij [ (G_i + G_j) X_ij + (C_i + C_j) Y_ij ], G = P/K - C F ; linear about u=0:
    # (G_i+G_j) X + (C_i+C_j) Y with Y = X + u_j - u_i: the constant parts cancel (G0 = -C), leaving
    # G'_i = E (F_i-1)/K_i - C_i (F_i-1) ; hourglass (C_i+C_j)(u_j-u_i)
    Gp = (E/K - C)[:,None]*Fm
    L = (A*X).sum(1)[:,None]*Gp + (A*X)@Gp     # sum_j A X (G_i + G_j)
    H = A*(C[:,None]+C[None,:]); L += H; L[np.diag_indices(Ns)] -= H.sum(1)
    return xs, L, Fm   # f = L u (force density), stress = E Fm u
def run(hf, rho2, K2, dx=2e-3, Ns=250, Nf=250, hp=None, hor=3.0, chg=0.01, wc=2.0, mode=None, phi=None, aconst=None, pw=1.0):
    xs, L, Fm = solid_matrix(Ns, dx, hor, chg)
    h = hf*dx
    xf = (np.arange(Nf)+0.5)*dx
    def G(xa, xb, hh):
        d = xa[:,None]-xb[None,:]
        return (2/3)/hh**2*dfk(np.abs(d)/hh)*np.sign(d)
    Gff = G(xf,xf,h); Gfs = G(xf,xs,h)
    if hp is not None:
        D = G(xf,xs,hp*dx); C = Gfs.sum(1); Dd = D.sum(1)
        al = np.where(np.abs(Dd)>0, C/np.where(Dd==0,1,Dd), 0)
        Gfs = al[:,None]*D
    if mode == 'ideal':
        c = cprofile(Ns, dx, hor); ph = np.zeros(Ns); ph[-8:] = -c[-8:]; ph /= ph.sum()
        Gfs = Gfs.sum(1)[:,None]*ph[None,:]
    if mode in ('pd1','pd2','pd3','pd4','pd5','pd6'):
        hor_=hor; delta=hor_*dx
        Xs = xs[None,:]-xs[:,None]; rs=np.abs(Xs)
        bs = np.clip((delta+0.5*dx-rs)/dx,0,1); np.fill_diagonal(bs,0)
        Kk = (bs*dx*Xs*Xs).sum(1); Kb = Kk[0]
        Xfi = xf[:,None]-xs[None,:]   # X_ki = x_i - x_k (from solid k to fluid i), shape (Nf, Ns)
        b = np.clip((delta+0.5*dx-np.abs(Xfi))/dx,0,1)
        if mode=='pd1': kap = 1/Kk[None,:] + 1/Kb
        elif mode=='pd2': kap = 1/Kk[None,:]
        elif mode=='pd3': kap = np.ones_like(Xfi)/Kb
        elif mode=='pd4': kap = (1/Kk[None,:])*np.clip(1-np.abs(Xfi)/(delta+0.5*dx),0,1)
        elif mode=='pd5': kap = (1/Kk[None,:])*(dx/np.abs(Xfi))**pw
        else: kap = (1/Kk[None,:])**2*Kb
        psi = -b*dx*kap*Xfi    # gradient-like wrt x_i: sign so that rows have the sign of Gfs
        rs_ = psi.sum(1); C = Gfs.sum(1)
        al = np.where(np.abs(rs_)>1e-30, C/np.where(rs_==0,1,rs_), 0)
        if aconst is not None: al = aconst*np.ones_like(al)/dx
        Gfs = al[:,None]*psi
    if phi is not None:
        ph = np.zeros(Ns); ph[-len(phi):] = np.array(phi)[::-1]; ph /= ph.sum()
        Gfs = Gfs.sum(1)[:,None]*ph[None,:]
    V = dx
    c1=np.sqrt(E/rho1); Z1=np.sqrt(E*rho1); c2=np.sqrt(K2/rho2); Z2=np.sqrt(K2*rho2)
    W=0.1; xc=-0.15; v0=1.0
    shape = np.where(np.abs(xs-xc)<W/2, np.cos(np.pi*(xs-xc)/W)**2, 0.0)
    vs = v0*shape.copy(); us = np.cumsum(-vs/c1)*dx
    vf = np.zeros(Nf); rf = np.zeros(Nf)
    dt = 0.2*dx/max(c1,c2)
    t_end = 0.12/c1 + 0.15/c1
    Gfs_row = Gfs.sum(1)
    def acc(us, vs, vf, rf):
        sf = -K2*rf/rho2
        af = (V/rho2)*((Gff*(sf[:,None]+sf[None,:])).sum(1)) + 2*(V/rho2)*sf*Gfs_row
        Fij = (rho2*V)*2*(V/rho2)*sf[:,None]*Gfs
        as_ = (L@us)/rho1 - Fij.sum(0)/(rho1*V)
        return as_, af
    def drho(vs, vf):
        return rho2*V*((vf[:,None]-vf[None,:])*Gff).sum(1) + wc*rho2*V*((vf[:,None]-vs[None,:])*Gfs).sum(1)
    t=0
    as_, af = acc(us,vs,vf,rf)
    while t < t_end:
        vs += 0.5*dt*as_; vf += 0.5*dt*af
        us += dt*vs; rf += dt*drho(vs,vf)
        as_, af = acc(us,vs,vf,rf)
        vs += 0.5*dt*as_; vf += 0.5*dt*af
        t += dt
    ss = E*(Fm@us)
    sig_i = -Z1*v0
    win = xs < -0.02
    R = ss[win][np.argmax(np.abs(ss[win]))]/sig_i
    sf = -K2*rf/rho2
    T = sf[xf>0.02][np.argmax(np.abs(sf[xf>0.02]))]/sig_i
    Te, Re = 2*Z2/(Z1+Z2), (Z2-Z1)/(Z1+Z2)
    return 100*(T/Te-1), 100*(R/Re-1)
def cprofile(Ns, dx, hor=3.0):
    xs = (np.arange(-Ns,0)+0.5)*dx
    X = xs[None,:]-xs[:,None]; r=np.abs(X); delta=hor*dx
    beta = np.clip((delta+0.5*dx-r)/dx, 0, 1); np.fill_diagonal(beta,0)
    A = beta*dx; K=(A*X*X).sum(1)
    f = (A*(1/K[:,None]+1/K[None,:])*X).sum(1)
    return f*dx   # per unit sigma (force per area on the layer)

if __name__=="__main__":
    import ast
    kw = ast.literal_eval(sys.argv[1]) if len(sys.argv)>1 else {}
    hs = kw.pop('hs',[1.2,1.3,1.5,1.75,2.0,2.5])
    for hf in hs:
        out=[]
        for rho2,K2 in [(1000,2.5e8),(4000,4e9)]:
            out += run(hf,rho2,K2,**kw)
        print(hf, kw, " ".join("%+.2f"%o for o in out), flush=True)
