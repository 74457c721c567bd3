/*---------------------------------------------------------------------------*\
    stepServerDisplacementPointPatchVectorField: the one link per case.
    endpoint(): where to connect, from the entries. connect(): every rank's undeformed patch points gathered on the master,
    which connects and sends them all in one HELLO. exchange(): the master's
    REQUEST, each rank's slice of the DISPLACEMENT sent back to it. Ranks
    without whale points take part in the collective calls only.
\*---------------------------------------------------------------------------*/

#include "stepServerDisplacementPointPatchVectorField.H"
#include "Time.H"
#include "polyMesh.H"
#include "pointFields.H"
#include "points0MotionSolver.H"
#include "IPstream.H"
#include "OPstream.H"
#include "SubList.H"

#include <cstdlib>

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{

stepServer::Endpoint
stepServerDisplacementPointPatchVectorField::endpoint() const
{
    stepServer::Endpoint ep;
    if (port_ > 0)
    {
        ep.host = host_;
        ep.port = int(port_);
    }
    else if (!socket_.empty())
    {
        fileName s(socket_);
        s.expand();
        ep.socketPath = s;
    }
    else if (!endpointFile_.empty())
    {
        fileName f(endpointFile_);
        f.expand();
        ep.endpointFile = f;
    }
    else
    {
        // The global case's endpoint file, as the server writes it
        ep.endpointFile =
            this->db().time().globalPath()/stepServer::defaults::endpointFile;
    }
    ep.connectTimeout = connectTimeout_;
    ep.replyTimeout = replyTimeout_;
    return ep;
}


void stepServerDisplacementPointPatchVectorField::connect()
{
    const polyMesh& mesh = this->internalField().mesh()();

    // Undeformed coordinates: the motion solver's own points0
    // (points0 if present, else polyMesh/points from constant), not the
    // current, possibly already moved, mesh points
    const pointIOField points0(points0MotionSolver::points0IO(mesh));
    if (points0.size() != mesh.nPoints())
    {
        FatalErrorInFunction
            << "stepServer: " << points0.objectPath() << " has "
            << points0.size() << " points, the mesh " << mesh.nPoints()
            << exit(FatalError);
    }

    // Every rank's patch points to the master, once (collective: ranks
    // without whale faces take part with an empty list)
    List<pointField> allPts(Pstream::nProcs());
    allPts[Pstream::myProcNo()] = pointField(points0, this->patch().meshPoints());
    Pstream::gatherList(allPts);
    state_->started = true;

    if (!Pstream::master())
    {
        return;
    }

    // The master keeps each rank's share: the displacement comes back in
    // rank order and is cut into these slices
    state_->sizes.setSize(Pstream::nProcs());
    std::vector<double> pts;
    for (label proci = 0; proci < Pstream::nProcs(); ++proci)
    {
        state_->sizes[proci] = allPts[proci].size();
        for (const point& p : allPts[proci])
        {
            pts.push_back(p.x());
            pts.push_back(p.y());
            pts.push_back(p.z());
        }
    }

    const stepServer::Endpoint ep(endpoint());
    state_->client.reset(new stepServer::stepServerClient(ep));

    try
    {
        state_->client->connect();
    }
    catch (const stepServer::stepServerError& e)
    {
        state_->failed = true;
        FatalErrorInFunction
            << "stepServer: " << e.what() << nl
            << "    Is the step-server running for this case? Start it with:"
            << nl << "        whale-adapter serve --case "
            << this->db().time().globalPath().c_str()
            << "  (--tcp PORT --host H to listen on TCP)" << nl
            << "    and check the 'socket', 'port' or 'endpoint' entry of patch "
            << this->patch().name() << " in pointDisplacement."
            << exit(FatalError);
    }

    stepServer::Welcome w;
    try
    {
        // The token from the environment only: never from (or into) a
        // file of the case
        const char* token = std::getenv(stepServer::defaults::tokenEnv);
        w = state_->client->hello
        (
            Pstream::nProcs(), token ? std::string(token) : std::string(), pts
        );
    }
    catch (const stepServer::stepServerError& e)
    {
        state_->failed = true;
        FatalErrorInFunction
            << "stepServer: HELLO failed on patch " << this->patch().name()
            << ": " << e.what() << exit(FatalError);
    }

    Info<< "stepServer: connected to "
        << state_->client->connectedTo().c_str()
        << " on patch " << this->patch().name()
        << " (one link for " << Pstream::nProcs() << " rank(s), master sent "
        << pts.size()/3 << " points); max mapping distance "
        << w.maxMappingDistance << " m, internal step "
        << w.internalStep << " s" << endl;
}


vectorField stepServerDisplacementPointPatchVectorField::exchange
(
    const vector& fp,
    const vector& fv
)
{
    const Time& t = this->db().time();
    vectorField disp(this->size(), Zero);

    if (!Pstream::master())
    {
        // This rank's slice, from the master (which sends nothing to a
        // rank without patch points)
        if (this->size())
        {
            IPstream fromMaster
            (
                Pstream::commsTypes::scheduled, Pstream::masterNo()
            );
            fromMaster >> disp;
        }
        return disp;
    }

    std::vector<double> d;
    try
    {
        d = state_->client->request
        (
            t.value(),
            {fp.x(), fp.y(), fp.z()},
            {fv.x(), fv.y(), fv.z()}
        );
    }
    catch (const stepServer::stepServerError& e)
    {
        state_->failed = true;
        FatalErrorInFunction
            << "stepServer: REQUEST at time " << t.timeName()
            << " on patch " << this->patch().name() << " failed: "
            << e.what() << exit(FatalError);
    }

    vectorField all(d.size()/3);
    forAll(all, i)
    {
        all[i] = vector(d[3*i], d[3*i + 1], d[3*i + 2]);
    }

    const labelList& sizes = state_->sizes;
    label offset = sizes[Pstream::masterNo()];
    disp = SubList<vector>(all, offset, 0);
    for (label proci = 1; proci < Pstream::nProcs(); ++proci)
    {
        if (sizes[proci])
        {
            OPstream toProc(Pstream::commsTypes::scheduled, proci);
            toProc << SubList<vector>(all, sizes[proci], offset);
        }
        offset += sizes[proci];
    }
    return disp;
}


} // End namespace Foam

// ************************************************************************* //
