/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | OpenFOAM: The Open Source CFD Toolbox
   \\    /   O peration     |
    \\  /    A nd           | www.openfoam.com
     \\/     M anipulation  |
-------------------------------------------------------------------------------
    Shape copied from OpenFOAM's oscillatingDisplacementPointPatchVectorField,
    Copyright (C) 2011-2016 OpenFOAM Foundation, GPL-3.0-or-later.
\*---------------------------------------------------------------------------*/

#include "stepServerDisplacementPointPatchVectorField.H"
#include "pointPatchFields.H"
#include "addToRunTimeSelectionTable.H"
#include "Time.H"
#include "polyMesh.H"
#include "fvMesh.H"
#include "pointFields.H"
#include "points0MotionSolver.H"
#include "patchLoads.H"

#include <chrono>
#include <iomanip>
#include <limits>
#include <sstream>

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{

namespace defaults = stepServer::defaults;

// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void stepServerDisplacementPointPatchVectorField::readEntries
(
    const dictionary& dict
)
{
    socket_ = dict.getOrDefault<fileName>("socket", fileName::null);
    host_ = dict.getOrDefault<string>("host", "127.0.0.1");
    port_ = dict.getOrDefault<label>("port", 0);
    endpointFile_ = dict.getOrDefault<fileName>("endpoint", fileName::null);
    connectTimeout_ =
        dict.getOrDefault<scalar>("connectTimeout", defaults::connectTimeout);
    replyTimeout_ =
        dict.getOrDefault<scalar>("replyTimeout", defaults::replyTimeout);
    rhoInf_ = dict.getOrDefault<scalar>("rhoInf", patchLoads::defaultRhoInf);

    if (dict.found("port") && (port_ < 1 || port_ > 65535))
    {
        FatalIOErrorInFunction(dict)
            << "stepServer: port " << port_
            << " out of range, expected 1..65535" << exit(FatalIOError);
    }
    if
    (
        int(dict.found("port")) + int(dict.found("socket"))
      + int(dict.found("endpoint")) > 1
    )
    {
        FatalIOErrorInFunction(dict)
            << "stepServer: give one of socket (UNIX), port (TCP) or endpoint"
            << " (the server's endpoint file), not several"
            << exit(FatalIOError);
    }
    if (dict.found("token"))
    {
        FatalIOErrorInFunction(dict)
            << "stepServer: a 'token' entry is not read (it would be written"
            << " into every time folder): remove it and set the environment"
            << " variable " << defaults::tokenEnv << " for the master rank instead"
            << exit(FatalIOError);
    }
    if (dict.found("host") && !dict.found("port"))
    {
        FatalIOErrorInFunction(dict)
            << "stepServer: host given without port" << exit(FatalIOError);
    }
    if (!(connectTimeout_ > 0) || !(replyTimeout_ > 0))
    {
        FatalIOErrorInFunction(dict)
            << "stepServer: connectTimeout " << connectTimeout_
            << " and replyTimeout " << replyTimeout_
            << " must be > 0 (seconds)" << exit(FatalIOError);
    }
    if (!(rhoInf_ > 0))
    {
        FatalIOErrorInFunction(dict)
            << "stepServer: rhoInf " << rhoInf_ << " must be > 0 (kg/m3)"
            << exit(FatalIOError);
    }
}


void stepServerDisplacementPointPatchVectorField::patchForces
(
    vector& fp,
    vector& fv
) const
{
    const scalar nan = std::numeric_limits<scalar>::quiet_NaN();
    fp = vector(nan, nan, nan);
    fv = vector(nan, nan, nan);

    const polyMesh& pMesh = this->internalField().mesh()();
    if (!isA<fvMesh>(pMesh))
    {
        return;
    }
    const fvMesh& mesh = refCast<const fvMesh>(pMesh);
    const label patchi = mesh.boundaryMesh().findPatchID(this->patch().name());
    if (patchi < 0)
    {
        return;
    }

    // Collective (grad(U) across processor patches): every rank gets
    // here at every update, whatever its share of the patch
    const patchLoads loads(mesh, rhoInf_);
    if (loads.hasPressure())
    {
        fp = sum(loads.pressure(patchi));
    }
    if (loads.hasViscous())
    {
        fv = sum(loads.viscous(patchi));
    }
}


void stepServerDisplacementPointPatchVectorField::logStats() const
{
    const label n = state_->nRequests;
    const double meanUs = n > 0 ? 1e6*state_->exchangeSeconds/n : 0;
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << meanUs;
    Info<< "stepServer: " << n << " requests, mean " << os.str().c_str()
        << " us per exchange" << endl;
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

stepServerDisplacementPointPatchVectorField::
stepServerDisplacementPointPatchVectorField
(
    const pointPatch& p,
    const DimensionedField<vector, pointMesh>& iF
)
:
    fixedValuePointPatchField<vector>(p, iF),
    socket_(),
    host_("127.0.0.1"),
    port_(0),
    endpointFile_(),
    connectTimeout_(defaults::connectTimeout),
    replyTimeout_(defaults::replyTimeout),
    rhoInf_(patchLoads::defaultRhoInf),
    state_(std::make_shared<couplingState>())
{}


stepServerDisplacementPointPatchVectorField::
stepServerDisplacementPointPatchVectorField
(
    const pointPatch& p,
    const DimensionedField<vector, pointMesh>& iF,
    const dictionary& dict
)
:
    fixedValuePointPatchField<vector>(p, iF, dict, false),
    port_(0),
    connectTimeout_(defaults::connectTimeout),
    replyTimeout_(defaults::replyTimeout),
    rhoInf_(patchLoads::defaultRhoInf),
    state_(std::make_shared<couplingState>())
{
    readEntries(dict);

    // No connection here: utilities (decomposePar, ...) construct the field
    // too. Without a value, start from zero displacement.
    if (!dict.found("value"))
    {
        Field<vector>::operator=(Zero);
    }
}


stepServerDisplacementPointPatchVectorField::
stepServerDisplacementPointPatchVectorField
(
    const stepServerDisplacementPointPatchVectorField& ptf,
    const pointPatch& p,
    const DimensionedField<vector, pointMesh>& iF,
    const pointPatchFieldMapper& mapper
)
:
    fixedValuePointPatchField<vector>(ptf, p, iF, mapper),
    socket_(ptf.socket_),
    host_(ptf.host_),
    port_(ptf.port_),
    endpointFile_(ptf.endpointFile_),
    connectTimeout_(ptf.connectTimeout_),
    replyTimeout_(ptf.replyTimeout_),
    rhoInf_(ptf.rhoInf_),
    state_(std::make_shared<couplingState>())
{}


stepServerDisplacementPointPatchVectorField::
stepServerDisplacementPointPatchVectorField
(
    const stepServerDisplacementPointPatchVectorField& ptf,
    const DimensionedField<vector, pointMesh>& iF
)
:
    fixedValuePointPatchField<vector>(ptf, iF),
    socket_(ptf.socket_),
    host_(ptf.host_),
    port_(ptf.port_),
    endpointFile_(ptf.endpointFile_),
    connectTimeout_(ptf.connectTimeout_),
    replyTimeout_(ptf.replyTimeout_),
    rhoInf_(ptf.rhoInf_),
    state_(ptf.state_)
{}


// * * * * * * * * * * * * * * * * Destructor  * * * * * * * * * * * * * * * //

stepServerDisplacementPointPatchVectorField::
~stepServerDisplacementPointPatchVectorField()
{
    if
    (
        state_ && state_.use_count() == 1
     && state_->client && state_->client->connected()
    )
    {
        logStats();
        state_->client->bye();
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void stepServerDisplacementPointPatchVectorField::updateCoeffs()
{
    if (this->updated())
    {
        return;
    }

    if (!state_->writeError.empty())
    {
        FatalErrorInFunction
            << "stepServer: " << state_->writeError.c_str() << nl
            << "    The last time folder was written completely: start the"
            << " server again (whale-adapter serve --case <case>) and restart"
            << " OpenFOAM from the latest time." << exit(FatalError);
    }

    const bool first = !state_->started;
    if (first)
    {
        connect();
    }

    const auto start = std::chrono::steady_clock::now();

    // Forces from the fields at this mesh update (last completed step),
    // summed over the ranks; NaN for the first request of a connection
    vector fp, fv;
    patchForces(fp, fv);
    reduce(fp, sumOp<vector>());
    reduce(fv, sumOp<vector>());
    if (first)
    {
        const scalar nan = std::numeric_limits<scalar>::quiet_NaN();
        fp = vector(nan, nan, nan);
        fv = fp;
    }

    // The master's REQUEST for all points, each rank's slice scattered
    this->operator==(exchange(fp, fv));

    if (Pstream::master())
    {
        // The coupling cost per step as OpenFOAM sees it: forces reduced,
        // request and reply, displacements scattered
        state_->exchangeSeconds += std::chrono::duration<double>
        (
            std::chrono::steady_clock::now() - start
        ).count();
        ++state_->nRequests;
    }

    fixedValuePointPatchField<vector>::updateCoeffs();
}


void stepServerDisplacementPointPatchVectorField::write(Ostream& os) const
{
    const Time& t = this->db().time();
    if
    (
        state_->client && state_->client->connected()
     && t.writeTime() && state_->lastWriteIndex != t.timeIndex()
    )
    {
        state_->lastWriteIndex = t.timeIndex();
        try
        {
            state_->client->write(t.value());
        }
        catch (const stepServer::stepServerError& e)
        {
            // Not fatal here: OpenFOAM is writing this time folder, and a
            // FatalError now would leave it cut short (not restartable).
            // Finish the folder; the next update stops the run.
            state_->failed = true;
            state_->writeError =
                "WRITE at time " + t.timeName() + " failed: " + e.what();
            WarningInFunction
                << "stepServer: " << state_->writeError.c_str()
                << "; finishing this time folder, stopping at the next step"
                << endl;
        }
        logStats();
    }

    pointPatchField<vector>::write(os);
    if (!socket_.empty())
    {
        os.writeEntry("socket", socket_);
    }
    if (port_ > 0)
    {
        os.writeEntry("host", host_);
        os.writeEntry("port", port_);
    }
    if (!endpointFile_.empty())
    {
        os.writeEntry("endpoint", endpointFile_);
    }
    os.writeEntry("connectTimeout", connectTimeout_);
    os.writeEntry("replyTimeout", replyTimeout_);
    os.writeEntry("rhoInf", rhoInf_);
    writeEntry("value", os);
}


// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

makePointPatchTypeField
(
    pointPatchVectorField,
    stepServerDisplacementPointPatchVectorField
);

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

} // End namespace Foam

// ************************************************************************* //
