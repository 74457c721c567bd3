/*---------------------------------------------------------------------------*\
    stepServerLink: the one link per case. connect(): every rank's
    undeformed patch points gathered on the master, which connects and sends
    them all in one HELLO. exchange(): the loads summed over the ranks, the
    master's REQUEST, each rank's slice of the DISPLACEMENT sent back to it,
    the whale's frame to every rank's mesh (whaleFrame).
    Ranks without whale points take part in the collective calls only.
\*---------------------------------------------------------------------------*/

#include "stepServerLink.H"
#include "Time.H"
#include "polyMesh.H"
#include "fvMesh.H"
#include "pointMesh.H"
#include "pointFields.H"
#include "points0MotionSolver.H"
#include "loads/patchLoads.H"
#include "frame/whaleFrame.H"
#include "IPstream.H"
#include "OPstream.H"
#include "SubList.H"

#include <chrono>
#include <cstdlib>
#include <iomanip>
#include <limits>
#include <sstream>

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{

namespace
{

const polyMesh& meshOf(const pointPatch& patch)
{
    return patch.boundaryMesh().mesh()();
}

vector nanVector()
{
    const scalar nan = std::numeric_limits<scalar>::quiet_NaN();
    return vector(nan, nan, nan);
}

//- Pressure and viscous force (N) and their moments about the origin (N m)
//  on this rank's faces of the patch (class patchLoads), NaN where not
//  computable. Collective (the sums over the ranks): every rank
//  calls it at every update.
stepServer::Loads patchLoadSums(const pointPatch& patch, const scalar rhoInf)
{
    vector fp = nanVector(), fv = nanVector();
    vector mp = nanVector(), mv = nanVector();

    const polyMesh& pMesh = meshOf(patch);
    const label patchi = pMesh.boundaryMesh().findPatchID(patch.name());
    if (isA<fvMesh>(pMesh) && patchi >= 0)
    {
        const fvMesh& mesh = refCast<const fvMesh>(pMesh);
        const patchLoads loads(mesh, rhoInf);
        if (loads.hasPressure())
        {
            const vectorField f(loads.pressure(patchi));
            fp = sum(f);
            mp = sum(loads.moments(patchi, f));
        }
        if (loads.hasViscous())
        {
            const vectorField f(loads.viscous(patchi));
            fv = sum(f);
            mv = sum(loads.moments(patchi, f));
        }
    }

    // Summed over the ranks (a NaN on one rank makes the sum NaN)
    stepServer::Loads sums;
    for (vector* v : {&fp, &fv, &mp, &mv})
    {
        reduce(*v, sumOp<vector>());
    }
    for (direction k = 0; k < 3; ++k)
    {
        sums.pressureForce[k] = fp[k];
        sums.viscousForce[k] = fv[k];
        sums.pressureMoment[k] = mp[k];
        sums.viscousMoment[k] = mv[k];
    }
    return sums;
}


//- All unknown: the first REQUEST of a connection
stepServer::Loads unknownLoads()
{
    const double nan = std::numeric_limits<double>::quiet_NaN();
    stepServer::Loads l;
    for (auto* v :
         {&l.pressureForce, &l.viscousForce, &l.pressureMoment, &l.viscousMoment
         })
    {
        v->fill(nan);
    }
    return l;
}

} // End anonymous namespace


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

std::vector<double> stepServerLink::gather(const pointField& points)
{
    List<pointField> allPts(Pstream::nProcs());
    allPts[Pstream::myProcNo()] = points;
    Pstream::gatherList(allPts);

    std::vector<double> flat;
    if (Pstream::master())
    {
        // The displacement comes back in rank order and is cut into
        // slices of these sizes
        sizes_.setSize(Pstream::nProcs());
        forAll(allPts, proci)
        {
            sizes_[proci] = allPts[proci].size();
            for (const point& p : allPts[proci])
            {
                flat.insert(flat.end(), {p.x(), p.y(), p.z()});
            }
        }
    }
    return flat;
}


vectorField stepServerLink::scatter(const vectorField& all, const label nLocal)
{
    vectorField mine(nLocal, Zero);
    if (!Pstream::master())
    {
        // From the master, which sends nothing to a rank without points
        if (nLocal)
        {
            IPstream fromMaster(
                Pstream::commsTypes::scheduled,
                Pstream::masterNo()
            );
            fromMaster >> mine;
        }
        return mine;
    }

    label offset = sizes_[Pstream::masterNo()];
    mine = SubList<vector>(all, offset, 0);
    for (label proci = 1; proci < Pstream::nProcs(); ++proci)
    {
        if (sizes_[proci])
        {
            OPstream toProc(Pstream::commsTypes::scheduled, proci);
            toProc << SubList<vector>(all, sizes_[proci], offset);
        }
        offset += sizes_[proci];
    }
    return mine;
}


vectorField
stepServerLink::request(const pointPatch& patch, const stepServer::Loads& loads)
{
    const Time& t = meshOf(patch).time();
    stepServer::Displacement r;
    try
    {
        r = client_->request(t.value(), loads);
    }
    catch (const stepServer::stepServerError& e)
    {
        FatalErrorInFunction << "stepServer: REQUEST at time " << t.timeName()
                             << " on patch " << patch.name()
                             << " failed: " << e.what() << exit(FatalError);
    }

    const auto& u = r.frameVelocity;
    const auto& a = r.frameAcceleration;
    frameVelocity_ = vector(u[0], u[1], u[2]);
    frameAcceleration_ = vector(a[0], a[1], a[2]);

    const std::vector<double>& d = r.d;
    vectorField all(d.size() / 3);
    forAll(all, i)
    {
        all[i] = vector(d[3 * i], d[3 * i + 1], d[3 * i + 2]);
    }
    return all;
}


void stepServerLink::logStats() const
{
    const double meanUs =
        nRequests_ > 0 ? 1e6 * exchangeSeconds_ / nRequests_ : 0;
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << meanUs;
    Info << "stepServer: " << nRequests_ << " requests, mean "
         << os.str().c_str() << " us per exchange" << endl;
    const double n = nRequests_ > 0 ? nRequests_ : 1;
    std::ostringstream parts;
    parts << std::fixed << std::setprecision(1) << 1e6 * loadsSeconds_ / n
          << " us loads, " << 1e6 * requestSeconds_ / n;
    Info << "stepServer: of it " << parts.str().c_str()
         << " us request and reply" << endl;
}


// * * * * * * * * * * * * * * * * Destructor  * * * * * * * * * * * * * * * //

stepServerLink::~stepServerLink()
{
    if (client_ && client_->connected())
    {
        logStats();
        client_->bye();
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void stepServerLink::connect(
    const pointPatch& patch,
    const stepServer::Endpoint& ep
)
{
    const polyMesh& mesh = meshOf(patch);

    // Undeformed coordinates: the motion solver's own points0 (points0 if
    // present, else polyMesh/points from constant), not the current,
    // possibly already moved, mesh points
    const pointIOField points0(points0MotionSolver::points0IO(mesh));
    if (points0.size() != mesh.nPoints())
    {
        FatalErrorInFunction << "stepServer: " << points0.objectPath()
                             << " has " << points0.size()
                             << " points, the mesh " << mesh.nPoints()
                             << exit(FatalError);
    }

    const pointField mine(points0, patch.meshPoints());
    const std::vector<double> pts(gather(mine));
    started_ = true;
    if (!Pstream::master())
    {
        return;
    }

    client_.reset(new stepServer::stepServerClient(ep));
    try
    {
        client_->connect();
    }
    catch (const stepServer::stepServerError& e)
    {
        FatalErrorInFunction
            << "stepServer: " << e.what() << nl
            << "    Is the step-server running for this case? Start it with:"
            << nl << "        whale-adapter serve --case "
            << mesh.time().globalPath().c_str()
            << "  (--tcp PORT --host H to listen on TCP)" << nl
            << "    and check the 'socket', 'port' or 'endpoint' entry of "
               "patch "
            << patch.name() << " in pointDisplacement." << exit(FatalError);
    }

    stepServer::Welcome w;
    try
    {
        // The token from the environment only: never from (or into) a
        // file of the case
        const char* token = std::getenv(stepServer::defaults::tokenEnv);
        w = client_->hello(
            Pstream::nProcs(),
            token ? std::string(token) : std::string(),
            pts
        );
    }
    catch (const stepServer::stepServerError& e)
    {
        FatalErrorInFunction << "stepServer: HELLO failed on patch "
                             << patch.name() << ": " << e.what()
                             << exit(FatalError);
    }

    Info << "stepServer: connected to " << client_->connectedTo().c_str()
         << " on patch " << patch.name() << " (one link for "
         << Pstream::nProcs() << " rank(s), master sent " << pts.size() / 3
         << " points); max mapping distance " << w.maxMappingDistance
         << " m, internal step " << w.internalStep << " s" << endl;
}


vectorField
stepServerLink::exchange(const pointPatch& patch, const scalar rhoInf)
{
    if (!writeError_.empty())
    {
        FatalErrorInFunction
            << "stepServer: " << writeError_.c_str() << nl
            << "    The last time folder was written completely: start the"
            << " server again (whale-adapter serve --case <case>) and restart"
            << " OpenFOAM from the latest time." << exit(FatalError);
    }

    const auto start = std::chrono::steady_clock::now();

    // Loads from the fields at this mesh update (last completed step),
    // summed over the ranks; NaN for the first request of a connection
    stepServer::Loads loads = patchLoadSums(patch, rhoInf);
    const auto loadsDone = std::chrono::steady_clock::now();
    if (firstRequest_)
    {
        loads = unknownLoads();
        firstRequest_ = false;
    }

    vectorField all;
    if (Pstream::master())
    {
        all = request(patch, loads);
        using seconds = std::chrono::duration<double>;
        loadsSeconds_ += seconds(loadsDone - start).count();
        requestSeconds_ +=
            seconds(std::chrono::steady_clock::now() - loadsDone).count();
    }
    vectorField mine(scatter(all, patch.size()));

    // The whale's frame, the master's, on every rank's mesh
    Pstream::scatter(frameVelocity_);
    Pstream::scatter(frameAcceleration_);
    whaleFrame::set(meshOf(patch), frameVelocity_, frameAcceleration_);

    if (Pstream::master())
    {
        // The coupling cost per step as OpenFOAM sees it: loads reduced,
        // request and reply, displacements scattered
        exchangeSeconds_ += std::chrono::duration<double>(
                                std::chrono::steady_clock::now() - start
        )
                                .count();
        ++nRequests_;
    }
    return mine;
}


void stepServerLink::write(const Time& t)
{
    if (!client_ || !client_->connected() || !t.writeTime()
        || lastWriteIndex_ == t.timeIndex())
    {
        return;
    }
    lastWriteIndex_ = t.timeIndex();
    try
    {
        client_->write(t.value());
    }
    catch (const stepServer::stepServerError& e)
    {
        // Not fatal here: OpenFOAM is writing this time folder, and a
        // FatalError now would leave it cut short (not restartable).
        // Finish the folder; the next update stops the run.
        writeError_ = "WRITE at time " + t.timeName() + " failed: " + e.what();
        WarningInFunction
            << "stepServer: " << writeError_.c_str()
            << "; finishing this time folder, stopping at the next step"
            << endl;
    }
    logStats();
}


// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

} // End namespace Foam

// ************************************************************************* //
