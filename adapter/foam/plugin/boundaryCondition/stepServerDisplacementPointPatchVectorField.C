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
#include "pointFields.H"
#include "loads/patchLoads.H"
#include "common/gamgRestartOrder.H"

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{

namespace defaults = stepServer::defaults;

// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void stepServerDisplacementPointPatchVectorField::readEntries(
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
    const int nWays =
        dict.found("port") + dict.found("socket") + dict.found("endpoint");
    if (nWays > 1)
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
            << " variable " << defaults::tokenEnv
            << " for the master rank instead" << exit(FatalIOError);
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
            << " and replyTimeout " << replyTimeout_ << " must be > 0 (seconds)"
            << exit(FatalIOError);
    }
    if (!(rhoInf_ > 0))
    {
        FatalIOErrorInFunction(dict)
            << "stepServer: rhoInf " << rhoInf_ << " must be > 0 (kg/m3)"
            << exit(FatalIOError);
    }
}


stepServer::Endpoint stepServerDisplacementPointPatchVectorField::endpoint(
) const
{
    stepServer::Endpoint ep;
    if (port_ > 0)
    {
        ep.host = host_;
        ep.port = int(port_);
    }
    else if (!socket_.empty())
    {
        ep.socketPath = fileName(socket_).expand();
    }
    else if (!endpointFile_.empty())
    {
        ep.endpointFile = fileName(endpointFile_).expand();
    }
    else
    {
        // The global case's endpoint file, as the server writes it
        ep.endpointFile =
            this->db().time().globalPath() / defaults::endpointFile;
    }
    ep.connectTimeout = connectTimeout_;
    ep.replyTimeout = replyTimeout_;
    return ep;
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

stepServerDisplacementPointPatchVectorField::
    stepServerDisplacementPointPatchVectorField(
        const pointPatch& p,
        const DimensionedField<vector, pointMesh>& iF
    ) :
    fixedValuePointPatchField<vector>(p, iF),
    host_("127.0.0.1"),
    port_(0),
    connectTimeout_(defaults::connectTimeout),
    replyTimeout_(defaults::replyTimeout),
    rhoInf_(patchLoads::defaultRhoInf),
    link_(std::make_shared<stepServerLink>())
{}


stepServerDisplacementPointPatchVectorField::
    stepServerDisplacementPointPatchVectorField(
        const pointPatch& p,
        const DimensionedField<vector, pointMesh>& iF,
        const dictionary& dict
    ) :
    fixedValuePointPatchField<vector>(p, iF, dict, false),
    port_(0),
    connectTimeout_(defaults::connectTimeout),
    replyTimeout_(defaults::replyTimeout),
    rhoInf_(patchLoads::defaultRhoInf),
    link_(std::make_shared<stepServerLink>())
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
    stepServerDisplacementPointPatchVectorField(
        const stepServerDisplacementPointPatchVectorField& ptf,
        const pointPatch& p,
        const DimensionedField<vector, pointMesh>& iF,
        const pointPatchFieldMapper& mapper
    ) :
    fixedValuePointPatchField<vector>(ptf, p, iF, mapper),
    socket_(ptf.socket_),
    host_(ptf.host_),
    port_(ptf.port_),
    endpointFile_(ptf.endpointFile_),
    connectTimeout_(ptf.connectTimeout_),
    replyTimeout_(ptf.replyTimeout_),
    rhoInf_(ptf.rhoInf_),
    link_(std::make_shared<stepServerLink>())
{}


stepServerDisplacementPointPatchVectorField::
    stepServerDisplacementPointPatchVectorField(
        const stepServerDisplacementPointPatchVectorField& ptf,
        const DimensionedField<vector, pointMesh>& iF
    ) :
    fixedValuePointPatchField<vector>(ptf, iF),
    socket_(ptf.socket_),
    host_(ptf.host_),
    port_(ptf.port_),
    endpointFile_(ptf.endpointFile_),
    connectTimeout_(ptf.connectTimeout_),
    replyTimeout_(ptf.replyTimeout_),
    rhoInf_(ptf.rhoInf_),
    link_(ptf.link_)
{}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void stepServerDisplacementPointPatchVectorField::updateCoeffs()
{
    if (this->updated())
    {
        return;
    }

    // The first update connects (collective: every rank's points gathered);
    // the mesh's GAMG agglomeration starts forward after every motion, for
    // exact restarts (whatever the motion solver)
    if (!link_->started())
    {
        gamgRestartOrder::New(this->patch().boundaryMesh().mesh()());
        link_->connect(this->patch(), endpoint());
    }

    // The loads sent, this rank's slice of the displacement returned
    this->operator==(link_->exchange(this->patch(), rhoInf_));

    fixedValuePointPatchField<vector>::updateCoeffs();
}


void stepServerDisplacementPointPatchVectorField::write(Ostream& os) const
{
    // At a write time: WRITE(time), once per time
    link_->write(this->db().time());

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

makePointPatchTypeField(
    pointPatchVectorField,
    stepServerDisplacementPointPatchVectorField
);

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

} // End namespace Foam

// ************************************************************************* //
